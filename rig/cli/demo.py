"""``rig demo``: the section VII.B servo, identified, designed, simulated and run over the emulated bus."""

from __future__ import annotations

import argparse
import io
import sys
from typing import Any

from rig.cli.common import add_json, print_json

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """``rig demo``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    demo = sub.add_parser(
        "demo",
        help="design and simulate the DC position servo (section VII.B), then run it over the emulated bus",
        description="Identifies the emulated DC motor (PRBS over the emulated CAN bus), designs the DTSM "
        "(7.31) from the result, simulates (7.30) with and without its integral and the sign law (6.8), "
        "and runs (7.30) over the emulated bus; writes a run directory under runs/. Prints its report "
        "once it is whole (a progress line on a terminal meanwhile).",
    )
    add_json(demo, "print the same figures as one JSON object {design, simulations, identified, run}")
    demo.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from rig.cli.progress import Progress
    from rig.papers.demo import run_demo

    report = io.StringIO()  # printed whole: a demo a stop signal cuts short prints nothing
    record: dict[str, Any] = {}
    bar = Progress("rig demo", 3, "parts", json=args.json)
    try:
        code = run_demo(report, progress=bar.cycles, record=record)
    finally:
        bar.close()
    if args.json:
        print_json(record)
    else:
        sys.stdout.write(report.getvalue())
    return code
