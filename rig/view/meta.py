"""What a run's columns are, for the page: each column's unit and meaning, and per axis the
columns its chart holds (those shown at first: its reference, measurement and command, as
``rig.live.channels`` picks them; the others selectable).

An axis's chart holds the columns named ``<axis>.*``; the law's own columns (reference,
measurement, command and its internals) go to the chart of the first axis the law reads, the
loop's (``late``) to a chart named "loop". Everything comes from the run directory's
``columns.json`` and ``config.json`` (or, for a live run, the same files as the recorder wrote
them at its start): one path for a live run and a past one.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from rig.live.channels import channels_of

__all__ = ["LOOP", "meta_of", "read_meta"]

LOOP = "loop"  #: the chart of the loop's own columns
_LAW = ("reference", "measurement", "command")
_TIMING = ("read_us", "update_us", "write_us")  #: written after the row: not in the live ring


def meta_of(
    columns: Sequence[str], docs: Mapping[str, Mapping[str, str]], config: Mapping[str, Any], title: str
) -> dict[str, Any]:
    """The page's description of a run whose samples have ``columns`` (units in ``docs``), whose
    resolved configuration is ``config`` (config.json), named ``title``.

    Parameters
    ----------
    columns : Sequence[str]
        The samples' columns.
    docs : Mapping[str, Mapping[str, str]]
        Column -> its unit and meaning.
    config : Mapping[str, Any]
        The resolved configuration.
    title : str
        The run's name.

    Returns
    -------
    dict[str, Any]
        The description.
    """
    axes_cfg = [a for a in config.get("axes", []) if isinstance(a, dict) and "name" in a]
    modes = {str(a["name"]): (str(a.get("mode")) or None) for a in axes_cfg}
    for column in columns:  # a profile's axis (a load) has columns but no [[axis]]
        axis, dot, _ = column.partition(".")
        if dot and axis not in modes:
            modes[axis] = None
    controller = config.get("controller") or {}
    reads = [str(r) for r in controller.get("reads", [])]
    channels = {c.axis: c for c in channels_of(columns, docs, reads, modes)}
    law_axis = reads[0] if reads and reads[0] in modes else next(iter(modes), LOOP)
    charts: dict[str, dict[str, Any]] = {}
    for i, column in enumerate(columns):
        if i == 0:
            continue
        axis, dot, _ = column.partition(".")
        where = axis if dot else (LOOP if column == "late" or column in _TIMING else law_axis)
        chart = charts.setdefault(where, {"axis": where, "columns": [], "shown": []})
        chart["columns"].append(column)
    for name, chart in charts.items():
        channel = channels.get(name)
        shown = [columns[i] for i in channel.columns if i is not None] if channel else []
        chart["shown"] = shown or chart["columns"][:3]
        chart["mode"] = modes.get(name)
    order = [*modes, LOOP]
    return {
        "title": title,
        "columns": [
            {
                "name": c,
                "unit": str(docs.get(c, {}).get("unit", "")),
                "meaning": docs.get(c, {}).get("meaning", ""),
            }
            for c in columns
        ],
        "charts": [charts[n] for n in order if n in charts],
        "period": config.get("resolved_period"),
    }


def read_meta(run_dir: Path, columns: Sequence[str] | None = None) -> dict[str, Any]:
    """``meta_of`` a run directory (its columns from samples.csv's header unless given).

    Parameters
    ----------
    run_dir : Path
        The run.
    columns : Sequence[str] | None, optional
        Its columns (None: samples.csv's header).

    Returns
    -------
    dict[str, Any]
        The description.
    """
    if columns is None:
        with (run_dir / "samples.csv").open() as f:
            columns = f.readline().strip().split(",")
    return meta_of(columns, _json(run_dir / "columns.json"), _json(run_dir / "config.json"), run_dir.name)


def _json(path: Path) -> dict[str, Any]:
    """A JSON object from ``path`` ({} where it is missing, unreadable or not an object)."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}
