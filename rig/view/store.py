"""The runs, studies and identifications under the view's folders, read from disk, never written.

A folder holds run directories (``samples.csv`` or ``config.json`` in it: ``rig run``,
``rig identify``) and studies (``sweep.json`` in it: ``rig sweep``); a folder that is itself
one of them is shown as such. Every name in a request is looked up among what the folder holds
now (``ViewError`` 404 otherwise): a path is never built from a request's text, so nothing
outside the folders can be named, whatever the request spells (``..``, ``%2F``, a link).

- a run: its summary, configuration and columns (``rig.view.meta``); its samples as at most
  ``points`` rows, each bucket of rows as its minimum and maximum (``rig.host.readback``); its
  CAN trace (python-can's reader: ASC or BLF) filtered by COB-ID, a page at a time, each frame
  named by CiA 301's predefined connection set; its identification's frequency response;
- a study: sweep.json and the rows of results.parquet (pyarrow, the sweep extra).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from rig.host.readback import Envelope, read_rows
from rig.view.errors import ViewError, whole_number
from rig.view.meta import read_meta
from rig.view.trace import MAX_IDS, MAX_PAGE, cob_filter, frame_name, trace_page

__all__ = ["MAX_IDS", "MAX_PAGE", "MAX_POINTS", "Store", "ViewError", "cob_filter", "frame_name"]

MAX_POINTS = 20_000  #: rows of samples a request may ask for at most
MAX_JSON = 16 << 20  #: [B] a JSON file larger is not read


def _json(path: Path) -> Any:
    """The JSON document in ``path`` (None where it is missing, too large or unreadable)."""
    try:
        if path.stat().st_size > MAX_JSON:
            return None
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _clean(value: Any) -> Any:
    """``value`` for JSON: NaN and infinities as None."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


class Store:
    """The runs and studies under ``folders`` (each a folder of them, or one of them itself).

    Parameters
    ----------
    folders : list[Path]
        The folders.
    """

    def __init__(self, folders: list[Path]) -> None:
        self.folders = [Path(f) for f in folders]

    # --- what is there -------------------------------------------------------------------------
    def _entries(self) -> list[tuple[int, Path]]:
        """(folder index, directory) of every run and study the folders hold now."""
        found = []
        for i, folder in enumerate(self.folders):
            if _is_run(folder) or _is_study(folder):
                found.append((i, folder))
                continue
            try:
                children = sorted(os.scandir(folder), key=lambda e: e.name)
            except OSError:
                continue
            for entry in children:
                if entry.name.startswith(".") or not entry.is_dir(follow_symlinks=False):
                    continue
                path = Path(entry.path)
                if _is_run(path) or _is_study(path):
                    found.append((i, path))
        return found

    def _find(self, root: str, name: str, kind: str) -> Path:
        """The run (``kind`` "run") or study ("study") ``name`` of folder ``root``, looked up
        among those there; ViewError 404 otherwise."""
        for i, path in self._entries():
            if str(i) == root and path.name == name and (_is_run(path) if kind == "run" else _is_study(path)):
                return path
        raise ViewError(404, f"no {kind} {name[:80]!r} in folder {root[:8]!r}")

    def runs(self) -> list[dict[str, Any]]:
        """Every run directory, newest first: its name, folder, start, whether it goes on, its
        summary's main figures, and what it holds.

        Returns
        -------
        list[dict[str, Any]]
            One dict a run.
        """
        out = []
        for i, path in self._entries():
            if not _is_run(path):
                continue
            summary = _json(path / "summary.json")
            summary = summary if isinstance(summary, dict) else {}
            started = _json(path / "started.json")
            wall = started.get("wall_time") if isinstance(started, dict) else None
            if not isinstance(wall, (int, float)):
                wall = _mtime(path)
            out.append(
                {
                    "root": str(i),
                    "name": path.name,
                    "folder": str(self.folders[i]),
                    "started": wall,
                    "in_progress": not (path / "summary.json").exists(),
                    "cycles": summary.get("cycles"),
                    "stop_reason": summary.get("safe_stop_reason"),
                    "stop_confirmed": summary.get("stop_confirmed"),
                    "rms_error": _clean(summary.get("rms_error")),
                    "error_unit": summary.get("error_unit"),
                    "identification": (path / "identification.json").exists(),
                    "trace": _trace_file(path) is not None,
                }
            )
        return sorted(out, key=lambda r: -float(r["started"]))

    def studies(self) -> list[dict[str, Any]]:
        """Every study (sweep.json), newest first: its name, status and counts.

        Returns
        -------
        list[dict[str, Any]]
            One dict a study.
        """
        out = []
        for i, path in self._entries():
            if not _is_study(path):
                continue
            doc = _json(path / "sweep.json")
            doc = doc if isinstance(doc, dict) else {}
            out.append(
                {
                    "root": str(i),
                    "name": path.name,
                    "folder": str(self.folders[i]),
                    "started": doc.get("started"),
                    "status": doc.get("status"),
                    "counts": doc.get("counts"),
                    "mtime": _mtime(path),
                }
            )
        return sorted(out, key=lambda r: -float(r["mtime"]))

    # --- a run ---------------------------------------------------------------------------------
    def run(self, root: str, name: str) -> dict[str, Any]:
        """A run's summary, configuration, description of its columns and files.

        Parameters
        ----------
        root : str
            The folder's index.
        name : str
            The run's.

        Returns
        -------
        dict[str, Any]
            Its summary, configuration, columns and files.
        """
        path = self._find(root, name, "run")
        meta = read_meta(path) if (path / "samples.csv").exists() else None
        return {
            "root": root,
            "name": name,
            "in_progress": not (path / "summary.json").exists(),
            "summary": _clean(_json(path / "summary.json")),
            "config": _clean(_json(path / "config.json")),
            "started": _json(path / "started.json"),
            "meta": meta,
            "files": sorted(p.name for p in path.iterdir() if p.is_file() and not p.name.startswith(".")),
            "trace": (_trace_file(path) or Path("")).name or None,
            "identification": (path / "identification.json").exists(),
        }

    def samples(self, root: str, name: str, points: str | None) -> tuple[list[str], Any]:
        """(the columns, the samples as at most ``points`` rows: an array of arrays, the buckets'
        minima and maxima where the run has more).

        Parameters
        ----------
        root : str
            The folder's index.
        name : str
            The run's.
        points : str | None
            Rows at most (None: the default).

        Returns
        -------
        tuple[list[str], Any]
            (the columns, the rows).

        Raises
        ------
        ViewError
            If ``points`` is not a whole number, or the run has no samples.
        """
        path = self._find(root, name, "run")
        most = whole_number(points, "points", 4000, 10, MAX_POINTS)
        csv = path / "samples.csv"
        if not csv.exists():
            raise ViewError(404, f"run {name!r} has no samples.csv")
        with csv.open("rb") as f:
            columns = f.readline().decode("utf-8", errors="replace").strip().split(",")
            count = max(0, _lines(f.fileno()) - 1)
            envelope = Envelope(count, len(columns), max(1, most // 2))
            try:
                for chunk in read_rows(f.fileno(), len(columns), count):
                    envelope.add(chunk)
            except ValueError as exc:
                raise ViewError(422, f"run {name!r}: samples.csv is not a table of numbers: {exc}") from exc
            rows = envelope.rows()
        return columns, _clean(rows.tolist())

    def trace(
        self, root: str, name: str, cob: str | None, offset: str | None, limit: str | None
    ) -> dict[str, Any]:
        """A page of the run's CAN frames whose COB-ID is in ``cob`` (``cob_filter``; all without):
        from the ``offset``-th match, ``limit`` of them, and how many match in all.

        Parameters
        ----------
        root : str
            The folder's index.
        name : str
            The run's.
        cob : str | None
            COB-IDs (``cob_filter``; None: all).
        offset : str | None
            The first match.
        limit : str | None
            Matches at most.

        Returns
        -------
        dict[str, Any]
            The page.

        Raises
        ------
        ViewError
            If a filter, offset or limit is wrong.
        """
        path = self._find(root, name, "run")
        ranges = cob_filter(cob or "")
        first = whole_number(offset, "offset", 0, 0, 10**9)
        count = whole_number(limit, "limit", 200, 1, MAX_PAGE)
        file = _trace_file(path)
        if file is None:
            raise ViewError(404, f"run {name!r} has no CAN trace")
        return trace_page(file, name, ranges, first, count)

    def identification(self, root: str, name: str) -> dict[str, Any]:
        """A run's identification.json.

        Parameters
        ----------
        root : str
            The folder's index.
        name : str
            The run's.

        Returns
        -------
        dict[str, Any]
            The document.

        Raises
        ------
        ViewError
            If the run has none, or it cannot be read.
        """
        path = self._find(root, name, "run")
        doc = _json(path / "identification.json")
        if not isinstance(doc, dict):
            raise ViewError(404, f"run {name!r} has no identification.json")
        return dict(_clean(doc))

    # --- a study -------------------------------------------------------------------------------
    def study(self, root: str, name: str) -> dict[str, Any]:
        """sweep.json and the rows of results.parquet (its varied parameters, metrics, errors).

        Parameters
        ----------
        root : str
            The folder's index.
        name : str
            The study's.

        Returns
        -------
        dict[str, Any]
            sweep.json and the rows.
        """
        path = self._find(root, name, "study")
        doc = _json(path / "sweep.json")
        doc = doc if isinstance(doc, dict) else {}
        rows: list[dict[str, Any]] = []
        problem = None
        if (path / "results.parquet").exists():
            try:
                from rig.sweep.table import read_rows as read_results

                rows = read_results(path)
            except ImportError:
                problem = "results.parquet needs pyarrow to be read: pip install 'drive-rig[sweep]'"
            except Exception as exc:
                problem = str(exc)
        spec = doc.get("spec") or {}
        return {
            "root": root,
            "name": name,
            "sweep": _clean({k: v for k, v in doc.items() if k != "base"}),
            "parameters": [p.get("name") for p in spec.get("parameters", []) if isinstance(p, dict)],
            "units": {
                p.get("name"): p.get("unit", "") for p in spec.get("parameters", []) if isinstance(p, dict)
            },
            "metrics": list(spec.get("metrics", [])),
            "rows": _clean(rows),
            "problem": problem,
        }


def _is_run(path: Path) -> bool:
    return (path / "samples.csv").is_file() or (path / "config.json").is_file()


def _is_study(path: Path) -> bool:
    return (path / "sweep.json").is_file()


def _trace_file(path: Path) -> Path | None:
    for name in ("trace.asc", "trace.blf"):
        if (path / name).is_file():
            return path / name
    return None


def _mtime(path: Path) -> float:
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0


def _lines(fd: int) -> int:
    """Whole lines of the file open as ``fd`` (a torn last one is none)."""
    n, offset = 0, 0
    while block := os.pread(fd, 1 << 20, offset):
        n += block.count(b"\n")
        offset += len(block)
    return n
