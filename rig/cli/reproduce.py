"""``rig reproduce dismc|dq-current``: a paper's numerical study, with --json, --plot and --param."""

from __future__ import annotations

import argparse
import dataclasses
import json
from typing import Any

import numpy as np

from rig.cli.common import Parser, UsageError, add_json, add_params, json_clean, params_of, print_json
from rig.papers.dismc import ALIASES, FIXED, PARAM_NAMES, DismcExample, run_dismc
from rig.papers.dq_current import DQ_FIXED, DQ_PARAM_NAMES, PRINTED_TABLES, DqStudy, dq_study

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    reproduce = sub.add_parser(
        "reproduce", help="reproduce a paper's numerical study", description="Reproduce a paper's study."
    )
    rsub = reproduce.add_subparsers(dest="study", required=True, parser_class=Parser)
    dismc = rsub.add_parser(
        "dismc",
        help="section 4 of the DISMC paper: Table 1 for DSMC, DISMC-LMI, DISMC-LQR, DISMC-AW-LQR",
        description="Runs (47)-(53) with K of (55) and (57). Uses the printed H of (50) unless "
        "--param H=solved. Parameters: " + ", ".join(PARAM_NAMES) + ".",
    )
    add_json(dismc, "print a list of JSON objects")
    dismc.add_argument("--plot", metavar="FILE", help="write Fig. 3-like plots to FILE")
    add_params(dismc, "override an example parameter by the paper's symbol; vectors 1,2, matrices 1,0;0,1")
    dismc.set_defaults(handler=_dismc)
    dq = rsub.add_parser(
        "dq-current",
        help="dq-current paper: Tables II-III and the cross-coupling of a q step (proposed vs PI)",
        description="Runs the controller (32)-(34)/(37) on the plant (29) (or the fine stationary-frame "
        "model) with the Table IV parameters. Parameters: " + ", ".join(DQ_PARAM_NAMES) + ".",
    )
    add_json(dq, 'print one object {"tables": [...], "cross_coupling": [...]}')
    dq.add_argument("--plot", metavar="FILE", help="write q-step responses in dq (Fig. 9(b)-like) to FILE")
    add_params(dq, "override: ratio (e.g. 1/27), L1 [H], R1 [Ohm], gamma, strategy, plant (exact|fine)")
    dq.set_defaults(handler=_dq)


def _dismc(args: argparse.Namespace) -> int:
    from rig.plots import plot_dismc

    where = "rig reproduce dismc: --param"
    values = params_of(args.param, DismcExample, where, aliases=ALIASES, fixed=FIXED)
    try:
        example = dataclasses.replace(DismcExample(), **values)
        runs = run_dismc(example)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise UsageError(f"{where}: {exc}") from exc
    if args.plot:
        plot_dismc(runs, args.plot, dt=example.Ts)
    rows = [{"controller": r.controller, **r.metrics} for r in runs]
    if args.json:
        print_json(rows)
        return 0
    print(f"DISMC paper, section 4 (H {example.H}; Ts = {example.Ts} s); Table 1 metrics:")
    print(f"  {'controller':14s} {'rise s':>8s} {'settling s':>11s} {'u_min':>9s} {'u_max':>9s}")
    for r in json_clean(rows):
        cells = [f"{v:.2f}" if isinstance(v, float) else "-" for v in list(r.values())[1:]]
        print(f"  {r['controller']:14s} {cells[0]:>8s} {cells[1]:>11s} {cells[2]:>9s} {cells[3]:>9s}")
    print(
        "  paper: DISMC-LMI 1.82 2.88 -60.6 135.8; DISMC-LQR 0.44 0.72 -32.7 175.1;"
        " DISMC-AW-LQR 0.32 0.38 -11.1 104.5"
    )
    return 0


def _dq(args: argparse.Namespace) -> int:
    from rig.plots import plot_dq_steps

    where = "rig reproduce dq-current: --param"
    values = params_of(args.param, DqStudy, where, fixed=DQ_FIXED)
    try:
        study = dataclasses.replace(DqStudy(), **values)
        rows, runs = dq_study(study)
    except ValueError as exc:
        raise UsageError(f"{where}: {exc}") from exc
    if args.plot:
        plot_dq_steps(runs, args.plot)
    cross = [
        {
            "strategy": r.strategy,
            "ratio": r.ratio,
            "controller": r.controller,
            "gamma": r.gamma,
            "peak_id": r.peak_id,
        }
        for r in runs
    ]
    if args.json:
        print(json.dumps({"tables": json_clean(rows), "cross_coupling": cross}))
        return 0
    _print_dq(study, rows, cross)
    return 0


def _print_dq(study: DqStudy, rows: list[dict[str, Any]], cross: list[dict[str, Any]]) -> None:
    print(
        f"dq-current paper, Tables II-III (plant {study.plant}, L1 = {study.L1:g} H, R1 = {study.R1:g} Ohm)"
    )
    print(
        f"  {'strategy':13s} {'variant':8s} {'gamma':>5s} {'bw/fs':>6s} {'GM dB':>6s} {'PM deg':>6s} "
        f"{'OS %':>5s} {'rise':>4s} {'settle':>6s}   printed: bw GM PM OS rise settle"
    )
    for row in rows:
        printed = PRINTED_TABLES[row["strategy"]].get(row["gamma"])
        cells = [
            row[k] for k in ("bandwidth_ratio", "gain_margin_db", "phase_margin_deg", "overshoot_percent")
        ]
        head = f"  {row['strategy']:13s} {row['variant']:8s} {row['gamma']:5.2f} "
        print(
            f"{head}{cells[0]:6.3f} {cells[1]:6.2f} {cells[2]:6.1f} {cells[3]:5.1f} "
            f"{row['rise_samples']:4.0f} {row['settling_samples']:6.0f}   "
            + (" ".join(f"{v:g}" for v in printed) if printed else "-")
        )
    print("Cross-coupling: peak |i_d| per unit q-reference step")
    for c in cross:
        print(
            f"  {c['strategy']:13s} w_k/w_s = 1/{1 / c['ratio']:<5.4g} gamma {c['gamma']:.2f} "
            f"{c['controller']:13s} {c['peak_id']:.4f}"
        )
