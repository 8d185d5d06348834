"""The engine of a study: Dask distributed, and the loop that streams its rows into the table.

The client it runs on is ``rig.sweep.cluster``'s (a local cluster, or a scheduler's). Every point is
one task (``Client.submit``); rows come back as they finish (``distributed.as_completed``) and go
into the table (``rig.sweep.table``). A worker lost mid-sweep costs only the points it held: the
scheduler runs them again elsewhere, and the table keeps each point once (rows by point number). A
task that fails outright (a worker that dies on it again and again: ``KilledWorker``) is a row with
its error. Ctrl-C cancels what has not finished and keeps what has. No pool, queue or retry of our
own: Dask's.
"""

from __future__ import annotations

import datetime
import logging
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from rig.sweep.cluster import close_client, cores, open_client
from rig.sweep.point import job_of, read_base, run_point
from rig.sweep.points import Point, make_points
from rig.sweep.spec import SweepSpec
from rig.sweep.table import Results, read_rows, read_sweep_json, write_sweep_json

__all__ = ["SweepRun", "close_client", "cores", "open_client", "resumable", "run_sweep"]

log = logging.getLogger(__name__)


@dataclass
class SweepRun:
    """What ``run_sweep`` did: the table, the counts, the seconds from the first task's submit
    to the last row, and the record written to sweep.json."""

    results: Results  #: the table
    total: int  #: points in the study
    resumed: int  #: rows kept from before
    seconds: float  #: [s] from the first submit to the last row
    record: dict[str, Any]  #: what sweep.json holds
    interrupted: bool = False  #: Ctrl-C ended it


def _pending(spec: SweepSpec, points: list[Point], rows: list[dict[str, Any]]) -> list[Point]:
    """The points not in the table yet; ConfigError when a row's values are not its point's."""
    by_index = {p.index: p for p in points}
    done = set()
    for row in rows:
        p = by_index.get(int(row["point"]))
        if p is None or any(row.get(k) != v for k, v in p.values.items()):
            raise ConfigError(
                f"{spec.directory}: the table's point {row['point']} is not this spec's point: start the "
                "sweep under another [sweep] name"
            )
        done.add(p.index)
    return [p for p in points if p.index not in done]


def resumable(spec: SweepSpec, resume: bool) -> list[dict[str, Any]]:
    """The rows to keep: none for a new sweep (ConfigError if the folder has a table and not
    ``resume``); the table's with ``resume`` (ConfigError if the spec changed).

    Parameters
    ----------
    spec : SweepSpec
        The study.
    resume : bool
        ``--resume``.

    Returns
    -------
    list[dict[str, Any]]
        The rows to keep.

    Raises
    ------
    ConfigError
        If the folder has a table and not ``resume``, or the spec changed.
    """
    record = read_sweep_json(spec.directory)
    rows = read_rows(spec.directory)
    if not resume:
        if record is not None or rows:
            raise ConfigError(
                f"rig sweep: {spec.directory} holds a sweep already: --resume to go on with it, or give "
                "[sweep] name (or output) another value"
            )
        return []
    old, new = _comparable(record.get("spec") if record else None), _comparable(_jsonable(spec.as_dict()))
    if record is not None and old != new:
        changed = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
        raise ConfigError(
            f"rig sweep --resume: {spec.source} is not the spec of {spec.directory} any more "
            f"(changed: {', '.join(changed)}): resume with the spec it was started with, or start anew"
        )
    return rows


def _comparable(spec: Any) -> dict[str, Any]:
    """A recorded spec as ``--resume`` compares it: the paths resolved (the same spec given from
    another folder is the same spec)."""
    doc = dict(spec or {})
    for key in ("source", "base"):
        if doc.get(key):
            doc[key] = str(Path(doc[key]).resolve())
    return doc


def _jsonable(doc: Any) -> Any:
    import json

    from rig.sweep.table import clean

    return json.loads(json.dumps(clean(doc)))


def run_sweep(
    spec: SweepSpec,
    client: Any,
    engine: dict[str, Any],
    *,
    resume: bool = False,
    on_row: Callable[[Results, int], None] | None = None,
    every: float = 1.0,
) -> SweepRun:
    """Run every point of ``spec`` not yet in its table on ``client``; ``on_row(results, total)``
    after each row. Returns when all are in, or on Ctrl-C (``interrupted``, the rows kept).

    Parameters
    ----------
    spec : SweepSpec
        The study.
    client : Any
        The dask client.
    engine : dict[str, Any]
        Its description.
    resume : bool, optional
        Keep the rows already in.
    on_row : Callable[[Results, int], None] | None, optional
        ``on_row(results, total)`` after each row.
    every : float, optional
        [s] between writes of the table.

    Returns
    -------
    SweepRun
        What it did.
    """
    base_doc = read_base(spec)
    points = make_points(spec)
    kept = resumable(spec, resume)
    todo = _pending(spec, points, kept)
    spec.directory.mkdir(parents=True, exist_ok=True)
    results = Results(spec.directory, kept, every=every)
    record = _record(spec, base_doc, engine, points=len(points), resumed=len(kept), results=results)
    write_sweep_json(spec.directory, record)
    results.write()
    token = uuid.uuid4().hex[:8]
    start = time.perf_counter()
    futures = {
        client.submit(run_point, job_of(spec, base_doc, p), key=f"rig-sweep-{token}-{p.index}", pure=False): p
        for p in todo
    }
    interrupted = _collect(client, futures, results, on_row, len(points))
    seconds = time.perf_counter() - start
    results.write()
    record["counts"] |= {"done": results.done, "failed": results.failed}
    record["status"] = "interrupted" if interrupted else "complete"
    record["finished"] = datetime.datetime.now().isoformat(timespec="seconds")
    record["seconds"] = seconds
    write_sweep_json(spec.directory, record)
    return SweepRun(results, len(points), len(kept), seconds, record, interrupted)


def _collect(
    client: Any,
    futures: dict[Any, Point],
    results: Results,
    on_row: Callable[[Results, int], None] | None,
    total: int,
) -> bool:
    """Each point's row into ``results`` as its run ends (``on_row(results, total)`` after each);
    True where Ctrl-C cut it short, the points not yet run cancelled."""
    from dask.distributed import as_completed

    try:
        for future in as_completed(list(futures)):  # type: ignore[no-untyped-call]
            results.add(_row(future, futures[future]))
            if on_row is not None:
                on_row(results, total)
    except KeyboardInterrupt:
        client.cancel(list(futures))
        return True
    return False


def _record(
    spec: SweepSpec,
    base_doc: dict[str, Any] | None,
    engine: dict[str, Any],
    *,
    points: int,
    resumed: int,
    results: Results,
) -> dict[str, Any]:
    """sweep.json as the study starts: the spec, the base configuration, the engine, the counts so
    far, the start's time, status running."""
    return {
        "spec": spec.as_dict(),
        "base": base_doc,
        "engine": engine,
        "counts": {
            "points": points,
            "resumed": resumed,
            "done": results.done,
            "failed": results.failed,
        },
        "started": datetime.datetime.now().isoformat(timespec="seconds"),
        "status": "running",
    }


def _row(future: Any, point: Point) -> dict[str, Any]:
    """The row a finished task returned, or one with the task's error (a worker that died on it
    each time it was given one: ``KilledWorker``; a cancelled task)."""
    try:
        row: dict[str, Any] = future.result()
        return row
    except Exception as exc:
        return {
            "point": point.index,
            **point.values,
            "seed": point.seed,
            "repeat": point.repeat,
            "error": f"{type(exc).__name__}: {exc}",
        }
