"""``rig design dtsm``: the delta model (6.9) and sliding vector (6.16)-(6.19) of (3.5)/(3.7) or (7.28)."""

from __future__ import annotations

import argparse
import json
import math
from typing import TYPE_CHECKING, Any

from rig.cli.common import Parser, UsageError, add_json, finite
from rig.cli.language import deprecated

if TYPE_CHECKING:
    from controllers.design import DTSMDesign

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """``rig design``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    design = sub.add_parser("design", help="design a controller", description="Design a controller.")
    dsub = design.add_subparsers(dest="kind", required=True, parser_class=Parser)
    dtsm = dsub.add_parser(
        "dtsm",
        help="DTSM sliding vector, eqs. (6.9), (6.16)-(6.19)",
        description="Design the delta-domain DTSM for dw/dt = -a_m w + b_m u with position "
        "(3.7), or the error-space model (7.28) with --error-space, at the sample period T (--period). "
        '--json prints the design with a_m, b_m, lam, dt (T) and input, a file [controller] design = "FILE" '
        "accepts. Example: "
        "rig design dtsm --from-identify runs/identify-voltage-... --lam -15 --error-space --json",
    )
    dtsm.add_argument("--a-m", type=finite, help="a_m [1/s] (or --from-identify)")
    dtsm.add_argument("--b-m", type=finite, help="b_m [rad/(V s^2)] (or --from-identify)")
    dtsm.add_argument(
        "--from-identify",
        metavar="FILE|RUN_DIR",
        help="take a_m, b_m (and the period unless --period) from rig identify's identification.json or "
        "run directory",
    )
    dtsm.add_argument(
        "--period", type=finite, metavar="S", help="sample period T [s], > 0 (default: --from-identify's)"
    )
    deprecated(dtsm, "--dt", "--period", "period", type=finite, metavar="S")
    dtsm.add_argument("--lam", type=finite, required=True, help="sliding eigenvalue lambda [1/s], < 0")
    dtsm.add_argument(
        "--error-space", action="store_true", help="use (7.28): e = [theta_r - theta, de/dt], b = [0, -b_m]"
    )
    add_json(dtsm, "print one JSON object")
    dtsm.set_defaults(handler=run)


def _design(args: argparse.Namespace) -> DTSMDesign:
    from controllers.design import design_dtsm
    from rig.config.model import read_model

    a_m, b_m = args.a_m, args.b_m
    args.input = "voltage"
    if args.from_identify:
        model = read_model(args.from_identify, where="rig design dtsm: --from-identify")
        a_m, b_m, args.input = model.a_m, model.b_m, model.input
        if args.period is None:
            args.period = model.dt  # the experiment's sample period, unless given
    if a_m is None or b_m is None:
        raise UsageError("rig design dtsm: give --a-m and --b-m, or --from-identify FILE|RUN_DIR")
    if args.period is None or math.isnan(args.period):
        raise UsageError("rig design dtsm: give --period (the sample period T [s])")
    if args.period <= 0.0:
        raise UsageError(f"rig design dtsm: argument --period: must be > 0 s, got {args.period:g}")
    if args.lam >= 0.0:
        raise UsageError(f"rig design dtsm: argument --lam: must be < 0 1/s, got {args.lam:g}")
    args.a_m, args.b_m = a_m, b_m
    b = -b_m if args.error_space else b_m
    try:
        return design_dtsm(A=[[0.0, 1.0], [0.0, -a_m]], b=[0.0, b], dt=args.period, lam=args.lam)
    except ValueError as exc:
        raise UsageError(
            f"rig design dtsm: --a-m {a_m:g} --b-m {b_m:g} --period {args.period:g}: {exc}"
        ) from exc


def run(args: argparse.Namespace) -> int:
    d = _design(args)
    if args.json:  # the model with the design: [controller] design = "FILE" reads it back
        model = {"a_m": args.a_m, "b_m": args.b_m, "lam": args.lam, "dt": d.dt, "input": args.input}
        print(json.dumps({**d.as_dict(), **model}))
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
