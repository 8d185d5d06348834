"""The results of a study: one row per point in ``results.parquet``, beside ``sweep.json``.

Rows are kept by point number (a point rescheduled after a lost worker is still one row) and
written as they come: the whole table, to a temporary file renamed over ``results.parquet``,
at most every ``every`` seconds and at the end, so the file on disk is always a whole table
(a killed sweep loses at most the last ``every`` seconds of rows). pyarrow writes it; pandas,
polars, DuckDB, Arrow in R or MATLAB's parquetread read it.

Columns: ``point``, the varied parameters by their dotted names, ``seed`` (the noise seed, null:
the base's own), ``repeat``, each metric, ``stop_reason``, ``error`` (null: it ran to its end),
``elapsed_s`` (the point's seconds in its worker), ``run_s`` (of them, the loop's or the
simulation's own), ``worker``, and for a rig run base ``error_unit`` and ``command_unit`` (the
units of its error and command figures).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from rig.host.storage import write_atomic

__all__ = ["RESULTS", "SWEEP", "Results", "clean", "read_rows", "read_sweep_json", "write_sweep_json"]

RESULTS = "results.parquet"
SWEEP = "sweep.json"


def read_rows(directory: Path) -> list[dict[str, Any]]:
    """The rows of ``directory``/results.parquet ([] when there is none); ConfigError when it
    cannot be read.

    Parameters
    ----------
    directory : Path
        The study's folder.

    Returns
    -------
    list[dict[str, Any]]
        The rows.

    Raises
    ------
    ConfigError
        If the table cannot be read.
    """
    import pyarrow.parquet as pq

    path = directory / RESULTS
    if not path.exists():
        return []
    try:
        rows: list[dict[str, Any]] = pq.read_table(path).to_pylist()
    except Exception as exc:  # pyarrow's ArrowInvalid and OSError alike
        raise ConfigError(f"{path}: not a results table: {exc}") from exc
    return rows


class Results:
    """The table of ``directory``: ``add(row)``; ``write()`` forces a write; ``done`` and
    ``failed`` count the rows.

    Parameters
    ----------
    directory : Path
        The study's folder.
    rows : list[dict[str, Any]] | None, optional
        Rows kept from before.
    every : float, optional
        [s] between writes.
    """

    def __init__(self, directory: Path, rows: list[dict[str, Any]] | None = None, every: float = 1.0) -> None:
        self.directory = directory
        self.rows: dict[int, dict[str, Any]] = {int(r["point"]): r for r in rows or []}
        self.every = every
        self._written = time.monotonic()
        self._dirty = False

    @property
    def done(self) -> int:
        return len(self.rows)

    @property
    def failed(self) -> int:
        return sum(1 for r in self.rows.values() if r.get("error") is not None)

    def add(self, row: dict[str, Any]) -> None:
        """Add ``row`` (by its point), writing the table when ``every`` has passed.

        Parameters
        ----------
        row : dict[str, Any]
            The row.
        """
        self.rows[int(row["point"])] = row
        self._dirty = True
        if time.monotonic() - self._written >= self.every:
            self.write()

    def write(self) -> None:
        """The whole table to results.parquet (atomically), if anything changed."""
        if not self._dirty and (self.directory / RESULTS).exists():
            return
        import pyarrow as pa
        import pyarrow.parquet as pq

        rows = [self.rows[k] for k in sorted(self.rows)]
        table = (
            pa.Table.from_pylist([_cells(r) for r in rows])
            if rows
            else pa.table({"point": pa.array([], pa.int64())})
        )
        write_atomic(self.directory / RESULTS, lambda f: pq.write_table(table, f), binary=True)
        self._written, self._dirty = time.monotonic(), False


def _cells(row: dict[str, Any]) -> dict[str, Any]:
    """A row's values as Parquet takes them: a NaN metric as a NaN double, lists and tables as
    JSON text."""
    return {k: json.dumps(v) if isinstance(v, (dict, list, tuple)) else v for k, v in row.items()}


def clean(v: Any) -> Any:
    """``v`` for JSON: NaN as null, infinities as "inf" and "-inf".

    Parameters
    ----------
    v : Any
        A value.

    Returns
    -------
    Any
        It for JSON.
    """
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [clean(x) for x in v]
    return v


def write_sweep_json(directory: Path, doc: dict[str, Any]) -> None:
    """sweep.json: the resolved spec, the engine and the counts (atomically).

    Parameters
    ----------
    directory : Path
        The study's folder.
    doc : dict[str, Any]
        The document.
    """
    write_atomic(directory / SWEEP, lambda f: f.write(json.dumps(clean(doc), indent=2) + "\n"))


def read_sweep_json(directory: Path) -> dict[str, Any] | None:
    """sweep.json of ``directory``; None where there is none.

    Parameters
    ----------
    directory : Path
        The study's folder.

    Returns
    -------
    dict[str, Any] | None
        Its document, or None.
    """
    from drivers.files import read_json

    path = directory / SWEEP
    if not path.exists():
        return None
    doc = read_json(path, what="sweep record")
    return doc if isinstance(doc, dict) else None
