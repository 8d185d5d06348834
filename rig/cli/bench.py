"""``rig bench NAME``: measure one thing and print figures ({"name", "value", "unit"} with --json)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rig.cli.common import UsageError, add_json, finite

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    """``rig bench``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
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
    stops = bench.add_argument_group("rig bench stops (and view: --runs, --seconds)")
    stops.add_argument("--period", type=finite, metavar="S", help="the period [s] (default 0.001)")
    stops.add_argument(
        "--load",
        type=int,
        action="append",
        metavar="N",
        help="busy processes loading the machine (default 0); repeat it to measure several loads, "
        "alternated, in one invocation (--load 0 --load 2)",
    )
    stops.add_argument("--runs", type=int, metavar="N", help="runs (default 20)")
    stops.add_argument("--seconds", type=finite, metavar="S", help="each run's length [s] (default 10)")
    add_json(bench, 'print a list of {"name", "value", "unit"}')
    bench.set_defaults(handler=run)


def _stops_options(args: argparse.Namespace) -> dict[str, Any]:
    """``rig bench stops``'s options given (UsageError for another benchmark, or a bad value)."""
    given = {
        k: getattr(args, k) for k in ("period", "load", "runs", "seconds") if getattr(args, k) is not None
    }
    takes = {"stops": set(given), "view": {"runs", "seconds"}}.get(args.name, set())
    if set(given) - takes:
        names = ", ".join(f"--{k}" for k in given if k not in takes)
        raise UsageError(f"rig bench {args.name}: {names}: only rig bench stops takes them")
    ranges = {"period": (0.0, 0.1, "s"), "load": (0, 64, "processes"), "runs": (1, 10_000, "runs")}
    ranges["seconds"] = (0.0, 3600.0, "s")
    for key, values in given.items():
        low, high, unit = ranges[key]
        for value in values if isinstance(values, list) else [values]:
            if not (low < value <= high if isinstance(low, float) else low <= value <= high):
                bounds = f"({low:g}, {high:g}]" if isinstance(low, float) else f"{low}..{high}"
                raise UsageError(
                    f"rig bench {args.name}: argument --{key}: must be in {bounds} {unit}, got {value:g}"
                )
    if "load" in given:
        given["loads"] = given.pop("load")
    return given


def run(args: argparse.Namespace) -> int:
    from rig.bench import BENCHMARKS, LONG
    from rig.cli.progress import Progress

    options = _stops_options(args)
    if args.name in LONG:
        bar = Progress(f"rig bench {args.name}", 0, "", json=args.json)
        try:
            figures = LONG[args.name](progress=bar.cycles, **options)
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
