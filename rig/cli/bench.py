"""``rig bench NAME``: measure one thing and print figures ({"name", "value", "unit"} with --json)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rig.cli.common import add_json

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    from rig.bench import BENCHMARKS

    bench = sub.add_parser(
        "bench",
        help="measure and print figures",
        description="Benchmarks (never part of the test run): "
        + "; ".join(
            f"{name}: {fn.__doc__.splitlines()[0] if fn.__doc__ else ''}" for name, fn in BENCHMARKS.items()
        ),
    )
    bench.add_argument("name", choices=sorted(BENCHMARKS), help="what to measure")
    add_json(bench, 'print a list of {"name", "value", "unit"}')
    bench.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from rig.bench import BENCHMARKS, LONG
    from rig.cli.progress import Progress

    if args.name in LONG:
        bar = Progress(f"rig bench {args.name}", 0, "", json=args.json)
        try:
            figures = LONG[args.name](progress=bar.cycles)
        finally:
            bar.close()
    else:
        figures = BENCHMARKS[args.name]()
    if args.json:
        print(json.dumps(figures))
    else:
        for f in figures:
            print(f"{f['name']:34s} {f['value']:>10} {f['unit']}")
    return 0
