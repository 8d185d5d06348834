"""``rig reproduce dismc|dq-current|drives``: a paper's numerical study, with --json, --plot and --param."""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import math
from typing import TYPE_CHECKING, Any

from rig.cli.common import (
    Lazy,
    Parser,
    UsageError,
    add_json,
    add_params,
    add_plot,
    json_clean,
    params_of,
    plot_folder,
    print_json,
)
from rig.cli.progress import Progress

if TYPE_CHECKING:
    from rig.papers.dq_current import DqStudy

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """``rig reproduce``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    reproduce = sub.add_parser(
        "reproduce", help="reproduce a paper's numerical study", description="Reproduce a paper's study."
    )
    rsub = reproduce.add_subparsers(dest="study", required=True, parser_class=Parser)
    dismc = rsub.add_parser(
        "dismc",
        help="section 4 of the DISMC paper: Table 1 for DSMC, DISMC-LMI, DISMC-LQR, DISMC-AW-LQR",
        description=_with_names(
            "Runs (47)-(53) with K of (55) and (57). Uses the printed H of (50) unless "
            "--param H=solved. Parameters: ",
            "dismc",
            "PARAM_NAMES",
        ),
    )
    add_json(dismc, "print a list of JSON objects")
    add_plot(dismc, "Fig. 3-like plots (dismc.png)")
    add_params(dismc, "override an example parameter by the paper's symbol; vectors 1,2, matrices 1,0;0,1")
    dismc.set_defaults(handler=_dismc)
    dq = rsub.add_parser(
        "dq-current",
        help="dq-current paper: Tables II-III and the cross-coupling of a q step (proposed vs PI)",
        description=_with_names(
            "Runs the controller (32)-(34)/(37) on the plant (29) (or the fine stationary-frame "
            "model) with the Table IV parameters. Parameters: ",
            "dq_current",
            "DQ_PARAM_NAMES",
        ),
    )
    add_json(dq, 'print one object {"tables": [...], "cross_coupling": [...]}')
    add_plot(dq, "the q-step responses in dq, Fig. 9(b)-like (dq-current.png)")
    add_params(dq, "override: ratio (e.g. 1/27), L1 [H], R1 [Ohm], gamma, strategy, plant (exact|fine)")
    dq.set_defaults(handler=_dq)
    drives = rsub.add_parser(
        "drives",
        help="the drives paper: (7.31), Table V, Figs. 9-10, the VII.B servo, VII.C IM speed, VII.D cascade",
        description=_with_names(
            "Designs (7.31) and Table V; runs the speed loop of Figs. 9-10 on the VII.B DC "
            "platform (section VII.A's text is missing), the VII.B position servo, the VII.C IM speed "
            "control and the VII.D cascade as pure simulations and over the emulated bus (lock-step; the "
            "IM on the emulated dyno). About 25 s in full. Parameters: ",
            "drives_study",
            "DRIVES_PARAM_NAMES",
        ),
    )
    add_json(
        drives,
        'print one object {"design", "table_v", "speed_loop", "position_servo", "im_speed", "cascade"}',
    )
    add_plot(drives, "one figure per experiment")
    add_params(drives, "override: horizons speed_t_end, servo_t_end, im_t_end [s], substeps, load [N m], bus")
    drives.set_defaults(handler=_drives)


def _with_names(text: str, module: str, names: str) -> Lazy:
    """``text``, the parameter names ``names`` of ``rig.papers.<module>`` and a full stop, made
    when the help is shown (the study's module imports numpy and the controllers)."""
    return Lazy(
        lambda: text + ", ".join(getattr(importlib.import_module(f"rig.papers.{module}"), names)) + "."
    )


def _dismc(args: argparse.Namespace) -> int:
    import numpy as np

    from rig.papers.dismc import ALIASES, FIXED, DismcExample, run_dismc
    from rig.papers.plots import plot_dismc

    where = "rig reproduce dismc: --param"
    values = params_of(args.param, DismcExample, where, aliases=ALIASES, fixed=FIXED)
    folder = plot_folder(args, "rig reproduce dismc", old_file=True)
    try:
        example = dataclasses.replace(DismcExample(), **values)
        runs = run_dismc(example)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise UsageError(f"{where}: {exc}") from exc
    if folder is not None:
        plot_dismc(runs, args.plot_file or str(folder / "dismc.png"), dt=example.Ts)
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
    from rig.papers.dq_current import DQ_FIXED, DqStudy, dq_study
    from rig.papers.plots import plot_dq_steps

    where = "rig reproduce dq-current: --param"
    values = params_of(args.param, DqStudy, where, fixed=DQ_FIXED)
    try:
        study = dataclasses.replace(DqStudy(), **values)
    except ValueError as exc:
        raise UsageError(f"{where}: {exc}") from exc
    folder = plot_folder(args, "rig reproduce dq-current", old_file=True)
    bar = Progress("rig reproduce dq-current", 2, "parts", json=args.json)
    try:
        rows, runs = dq_study(study, progress=bar.cycles)
    except ValueError as exc:
        raise UsageError(f"{where}: {exc}") from exc
    finally:
        bar.close()
    if folder is not None:
        plot_dq_steps(runs, args.plot_file or str(folder / "dq-current.png"))
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
    from rig.papers.dq_current import PRINTED_TABLES

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


def _drives(args: argparse.Namespace) -> int:
    from rig.papers.drives_study import DRIVES_FIXED, DrivesStudy, drives_study

    where = "rig reproduce drives: --param"
    values = params_of(args.param, DrivesStudy, where, fixed=DRIVES_FIXED)
    try:
        study = dataclasses.replace(DrivesStudy(), **values)
    except ValueError as exc:
        raise UsageError(f"{where}: {exc}") from exc
    folder = plot_folder(args, "rig reproduce drives")  # made, and matplotlib checked, before the runs
    bar = Progress("rig reproduce drives", 6, "parts", json=args.json)
    try:
        doc, signals = drives_study(study, progress=bar.cycles)
    finally:
        bar.close()
    if folder is not None:
        from rig.papers.plots import plot_drives

        plot_drives(signals, str(folder))
    if args.json:
        print_json(doc)
        return 0
    _print_drives(json_clean(doc))
    return 0


def _cell(value: Any, fmt: str) -> str:
    """``value`` in ``fmt``; "-" for none or NaN (not measured: the table's note says why)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        width = "".join(c for c in fmt.split(".", maxsplit=1)[0] if c.isdigit())
        return "-".rjust(int(width or 1))
    return format(value, fmt)


def _print_drives(doc: dict[str, Any]) -> None:
    d = doc["design"]
    print("Drives paper. (7.31), a_m = 16, b_m = 680, T = 0.4 ms, lambda = -15:")
    for key in ("A_delta", "b_delta", "c_delta", "c_delta_A_delta"):
        print(f"  {key:16s} {d[key]}  printed {d['printed'][key]}")
    print("Table V: designed (6.16) | printed | used")
    for r in doc["table_v"]:
        print(
            f"  {r['name']:9s} k_s {r['k_s_designed']} | {r['k_s_printed']} | {r['k_s_used']};"
            f" c_s {r['c_s_designed']} | {r['c_s_printed']} | {r['c_s_used']}"
        )
        print(f"            {r['decision']}")
    print("Figs. 9-10 (VII.A's text is missing: the VII.B DC platform), speed-error amplitude over 2.5-5 s:")
    print(f"  {'':26s} {'sim rad/s':>11s} {'theory':>11s}")
    for r in doc["speed_loop"]:
        print(f"  {r['name']:26s} {_cell(r['error_amplitude'], '11.4g')} {_cell(r['theory'], '11.4g')}")
    head = (
        f"  {'':34s} {'bus':>3s} {'rms e':>9s} {'max |e|':>9s} {'e_ss':>10s} {'chatter':>7s} {'du rms':>9s}"
        f" {'sign %':>7s}"
    )
    for key, title in (
        ("position_servo", "Section VII.B position servo [rad; u in V]:"),
        ("im_speed", "Section VII.C IM speed under the VII.D load [rad/s; torque in N m]:"),
        ("cascade", "Section VII.D cascade [rad; i_q* in A]:"),
    ):
        print(title)
        print(head)
        for r in doc[key]:
            print(
                f"  {r['name']:34s} {'yes' if r['over_bus'] else 'no':>3s} {_cell(r['rms_error'], '9.3g')}"
                f" {_cell(r['max_error'], '9.3g')} {_cell(r['steady_state_error'], '10.2e')}"
                f" {_cell(r['chattering_count'], '7.0f')} {_cell(r['chattering_amplitude'], '9.2e')}"
                f" {_cell(None if r['sign_law_share'] is None else 100.0 * r['sign_law_share'], '7.3g')}"
            )
            if r.get("chattering_note"):
                print(f"  {'':34s} chatter {r['chattering_note']}")
    print(
        "chatter: sign alternations of the command increment beyond one step of the feedback's resolution's\n"
        "effect; sign %: the steady window's cycles outside the law's linear region (- : the law has\n"
        "none); docs/chattering.md"
    )
