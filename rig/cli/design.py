"""``rig design dtsm``: the delta model (6.9) and sliding vector (6.16)-(6.19) of (3.5)/(3.7) or (7.28)."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from controllers.design import DTSMDesign, design_dtsm
from drivers.errors import ConfigError
from drivers.files import read_json
from rig.cli.common import Parser, UsageError, add_json, finite

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    design = sub.add_parser("design", help="design a controller", description="Design a controller.")
    dsub = design.add_subparsers(dest="kind", required=True, parser_class=Parser)
    dtsm = dsub.add_parser(
        "dtsm",
        help="DTSM sliding vector, eqs. (6.9), (6.16)-(6.19)",
        description="Design the delta-domain DTSM for dw/dt = -a_m w + b_m u with position "
        "(3.7), or the error-space model (7.28) with --error-space.",
    )
    dtsm.add_argument("--a-m", type=finite, help="a_m [1/s] (or --from-identify)")
    dtsm.add_argument("--b-m", type=finite, help="b_m [rad/(V s^2)] (or --from-identify)")
    dtsm.add_argument("--from-identify", metavar="RESULT.json", help="take a_m, b_m from rig identify --json")
    dtsm.add_argument("--dt", type=finite, required=True, help="sample period T [s], > 0")
    dtsm.add_argument("--lam", type=finite, required=True, help="sliding eigenvalue lambda [1/s], < 0")
    dtsm.add_argument(
        "--error-space", action="store_true", help="use (7.28): e = [theta_r - theta, de/dt], b = [0, -b_m]"
    )
    add_json(dtsm, "print one JSON object")
    dtsm.set_defaults(handler=run)


def _from_identify(path: str) -> tuple[float, float, str]:
    """(a_m, b_m, input) of a ``rig identify --json`` result; ConfigError naming the file and key."""
    doc = read_json(path, what="rig identify result")
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: not a JSON object (the output of rig identify --json)")
    values = []
    for key in ("a_m", "b_m"):
        v = doc.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ConfigError(f"{path}: {key} = {v!r}: expected a finite number (from rig identify --json)")
        values.append(float(v))
    source = doc.get("input", "voltage")
    if source not in ("voltage", "torque"):
        raise ConfigError(f"{path}: input = {source!r}: expected voltage or torque")
    return values[0], values[1], source


def _design(args: argparse.Namespace) -> DTSMDesign:
    a_m, b_m = args.a_m, args.b_m
    args.input = "voltage"
    if args.from_identify:
        a_m, b_m, args.input = _from_identify(args.from_identify)
    if a_m is None or b_m is None:
        raise UsageError("rig design dtsm: give --a-m and --b-m, or --from-identify RESULT.json")
    if args.dt <= 0.0:
        raise UsageError(f"rig design dtsm: argument --dt: must be > 0 s, got {args.dt:g}")
    if args.lam >= 0.0:
        raise UsageError(f"rig design dtsm: argument --lam: must be < 0 1/s, got {args.lam:g}")
    b = -b_m if args.error_space else b_m
    try:
        return design_dtsm(A=[[0.0, 1.0], [0.0, -a_m]], b=[0.0, b], dt=args.dt, lam=args.lam)
    except ValueError as exc:
        raise UsageError(f"rig design dtsm: --a-m {a_m:g} --b-m {b_m:g} --dt {args.dt:g}: {exc}") from exc


def run(args: argparse.Namespace) -> int:
    d = _design(args)
    if args.json:
        extra = {"input": args.input} if args.from_identify else {}  # the model's input, when known
        print(json.dumps({**d.as_dict(), **extra}))
        return 0
    print(
        "\n".join(
            [
                f"DTSM design, T = {d.dt:g} s (eqs. 6.9, 6.16-6.19), input u: {args.input} "
                f"(the run must command the axis in {'CST' if args.input == 'torque' else 'voltage mode'})",
                f"  A_delta         = {[list(r) for r in d.A_delta]}",
                f"  b_delta         = {list(d.b_delta)}",
                f"  lambda_delta    = {d.lambda_delta:.10g} 1/s",
                f"  k_delta         = {list(d.k_delta)}",
                f"  c_delta         = {list(d.c_delta)}",
                f"  c_delta A_delta = {list(d.c_delta_A_delta)}",
            ]
        )
    )
    return 0
