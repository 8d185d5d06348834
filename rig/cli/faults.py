"""``rig faults``: every fault scenario over the whole chain, and what the host did about it."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rig.cli.common import Lazy, UsageError, add_json

__all__ = ["add_parser"]


def _description() -> str:
    from rig.faults.suite import SCENARIOS

    return (
        "Runs each scenario (" + ", ".join(SCENARIOS) + ") and prints when it was detected, "
        "whether the drive ended disabled, the samples lost, the motor's speed 1 s after the fault, "
        "whether the host confirmed its stop, and the operator's message."
    )


def add_parser(sub: Any) -> None:
    """``rig faults``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    faults = sub.add_parser(
        "faults",
        help="run every fault scenario over the whole chain and print the table",
        description=Lazy(_description),
    )
    add_json(faults, "print a list of JSON objects")
    faults.add_argument("--scenario", action="append", default=[], metavar="NAME", help="run only these")
    faults.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from rig.cli.progress import Progress
    from rig.faults.suite import SCENARIOS, run_faults

    unknown = [n for n in args.scenario if n not in SCENARIOS]
    if unknown:
        raise UsageError(f"rig faults: unknown scenario(s) {unknown}; known: {', '.join(SCENARIOS)}")
    bar = Progress("rig faults", 0, "scenarios", json=args.json)
    try:
        rows = run_faults(args.scenario or None, progress=bar.cycles)
    finally:
        bar.close()
    if args.json:
        print(json.dumps(rows))
        return 0
    print(
        f"{'scenario':18s} {'detected':>9s} {'disabled':>9s} {'lost':>5s} {'rad/s@1s':>9s} "
        f"{'confirmed':>9s}  message"
    )
    for r in rows:
        detected, lost, disabled, speed = (
            "-" if r[k] is None else str(r[k])
            for k in ("detected_after_cycles", "samples_lost", "drive_disabled", "motor_speed_after_1s")
        )
        print(
            f"{r['scenario']:18s} {detected:>9s} {disabled:>9s} {lost:>5s} {speed:>9s} "
            f"{r['stop_confirmed']!s:>9s}  {r['message']}"
        )
    return 0
