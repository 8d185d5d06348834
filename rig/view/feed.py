"""What feeds the live scope (``rig.view.scope.Scope``) beside a run, never the control thread itself.

- ``rig run --view``: the recorder writes each row into a ring in memory shared with the view's
  process, which reads it there ``RATE`` times a second (``rig.view.beside``, ``rig.view.ring_pump``);
  ``live_meta`` describes the run to the scope from the files the recorder wrote at its start.
- ``TailFeed``: a thread that follows a run directory's ``samples.csv`` as the recorder flushes
  it (every 50 ms of run time), for ``rig view RUN_DIR`` beside a run in another process; the run
  has ended when its ``summary.json`` is there. It reads the files only.
"""

from __future__ import annotations

import json
import logging
import os
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rig.host.columns import TIMING
from rig.view.meta import _json, meta_of, read_meta
from rig.view.scope import Scope, decimate

__all__ = ["RATE", "TAIL_BYTES", "TailFeed", "live_meta", "parse_lines"]

log = logging.getLogger(__name__)

RATE = 30.0  #: [1/s] updates of the live scope (at least 20 under load)
#: [s] a summary.json that does not parse for this long: the run ended without one
TORN_WAIT = 2.0
TAIL_BYTES = 4 << 20  #: of a run in progress's samples.csv read at the start (its last rows)


def live_meta(run_dir: Path, title: str) -> dict[str, Any]:
    """The description of the run in ``run_dir`` for the live scope, from the files the recorder
    wrote at its start; its columns are those of the rows the recorder hands a live view.

    Parameters
    ----------
    run_dir : Path
        The run's directory.
    title : str
        The run's name.

    Returns
    -------
    dict[str, Any]
        The run's description (``rig.view.meta.meta_of``).
    """
    docs = _json(run_dir / "columns.json")
    columns = list(docs)
    while columns and columns[-1] in TIMING:  # the stage times are not in the rows a live view gets
        columns.pop()
    return meta_of(columns, docs, _json(run_dir / "config.json"), title)


def parse_lines(lines: Sequence[bytes], width: int) -> np.ndarray:
    """Rows of ``width`` floats from CSV ``lines`` (a line that is not such a row is left out).

    Parameters
    ----------
    lines : Sequence[bytes]
        CSV lines.
    width : int
        Floats a row.

    Returns
    -------
    np.ndarray
        The rows.
    """
    rows = []
    for line in lines:
        parts = line.split(b",")
        if len(parts) != width:
            continue
        try:
            rows.append([float(p) for p in parts])
        except ValueError:
            continue
    return np.array(rows, dtype=float).reshape(len(rows), width)


class TailFeed:
    """A thread following ``run_dir``/samples.csv into ``scope`` ``RATE`` times a second until
    ``summary.json`` is there (or ``stop()``).

    Parameters
    ----------
    scope : Scope
        What it feeds.
    run_dir : Path
        The run.
    rate : float, optional
        [Hz].
    """

    def __init__(self, scope: Scope, run_dir: Path, rate: float = RATE) -> None:
        self.scope = scope
        self.run_dir = run_dir
        self.every = 1.0 / rate
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="rig-view-tail", daemon=True)

    def start(self) -> None:
        """Follow from a thread of its own."""
        self._thread.start()

    def stop(self) -> None:
        """Stop following."""
        self._stop.set()
        self._thread.join(2.0)

    def _run(self) -> None:
        try:
            self._follow()
        except Exception as exc:  # the view goes on with what it has
            log.warning("rig view: following %s stopped: %s", self.run_dir, exc)
            self.scope.stop()

    def _follow(self) -> None:
        samples = self.run_dir / "samples.csv"
        while not samples.exists() or samples.stat().st_size == 0:
            if self._stop.wait(self.every):
                return
        with samples.open("rb") as f:
            header = f.readline()
            width = len(header.split(b","))
            self.scope.open(read_meta(self.run_dir, header.decode().strip().split(",")))
            offset = max(f.tell(), os.fstat(f.fileno()).st_size - TAIL_BYTES)
            tail, skip = b"", offset > f.tell()  # a start inside a row: up to its end is no row
            torn = 0
            while True:
                ended = (self.run_dir / "summary.json").exists()  # before the read: its rows are in
                block = os.pread(f.fileno(), 1 << 22, offset)
                offset += len(block)
                lines = (tail + block).split(b"\n")
                tail = lines.pop()
                if skip and lines:
                    lines, skip = lines[1:], False
                if lines:
                    self.scope.push(decimate(parse_lines(lines, width)))
                if ended and len(block) < 1 << 22:
                    summary = _summary(self.run_dir / "summary.json")
                    torn += 1  # a summary written in place, not atomically, may read half-written
                    if summary is not None or torn * self.every > TORN_WAIT:
                        self.scope.finish(summary or {})
                        return
                if self._stop.wait(self.every):
                    return


def _summary(path: Path) -> dict[str, Any] | None:
    """The run's summary; None while it does not parse (a file still being written)."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) else {}
