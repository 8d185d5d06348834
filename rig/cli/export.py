"""``rig export RUN_DIR --format mf4|parquet|mat|csv``: a run's samples for other tools."""

from __future__ import annotations

import argparse
from typing import Any

from rig.cli.common import add_json, print_json

__all__ = ["add_parser"]

FORMATS = ("mf4", "parquet", "mat", "csv")  #: rig.host.export.FORMATS, without importing numpy here


def add_parser(sub: Any) -> None:
    """``rig export``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    export = sub.add_parser(
        "export",
        help="write a run's samples as MF4, Parquet, MAT or CSV",
        description="Writes the samples of a run directory (samples.csv, with each column's unit and "
        "meaning from columns.json) as ASAM MDF 4 (asammdf), Apache Parquet (pyarrow), MATLAB or CSV; "
        "MF4 and Parquet need the export extra: python -m pip install 'drive-rig[export]'.",
    )
    export.add_argument("run_dir", metavar="RUN_DIR", help="a run directory (runs/<name>-<time>)")
    export.add_argument("--format", required=True, choices=FORMATS, help="the file format")
    export.add_argument(
        "--output", metavar="FILE", help="the file to write (default: RUN_DIR.<format>, beside RUN_DIR)"
    )
    add_json(export, 'print one JSON object {"written": FILE, "format": FORMAT}')
    export.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from rig.host.export import export_run

    written = export_run(args.run_dir, args.format, args.output)
    if args.json:
        print_json({"written": str(written), "format": args.format})
    else:
        print(f"written to {written}")
    return 0
