"""``rig faults``: every fault scenario over the whole chain, and what the host did about it."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rig.cli.common import UsageError, add_json

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    from rig.fault_suite import SCENARIOS

    faults = sub.add_parser(
        "faults",
        help="run every fault scenario over the whole chain and print the table",
        description="Runs each scenario (" + ", ".join(SCENARIOS) + ") and prints when it was detected, "
        "whether the drive ended disabled, the samples lost and the operator's message.",
    )
    add_json(faults, "print a list of JSON objects")
    faults.add_argument("--scenario", action="append", default=[], metavar="NAME", help="run only these")
    faults.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from rig.fault_suite import SCENARIOS, run_faults

    unknown = [n for n in args.scenario if n not in SCENARIOS]
    if unknown:
        raise UsageError(f"rig faults: unknown scenario(s) {unknown}; known: {', '.join(SCENARIOS)}")
    rows = run_faults(args.scenario or None)
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{'scenario':18s} {'detected':>9s} {'disabled':>9s} {'lost':>5s}  message")
    for r in rows:
        detected = "-" if r["detected_after_cycles"] is None else str(r["detected_after_cycles"])
        lost = "-" if r["samples_lost"] is None else str(r["samples_lost"])
        print(f"{r['scenario']:18s} {detected:>9s} {r['drive_disabled']!s:>9s} {lost:>5s}  {r['message']}")
    return 0
