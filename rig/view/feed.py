"""What feeds the live scope (``rig.view.scope.Scope``), never the control thread itself.

- ``RingFeed``: a backend of ``rig.live.view.LiveView`` (``rig run --view``). The loop's only
  part is the recorder's O(1) append of each row to the LiveView's ring (a bounded deque, no
  lock); the LiveView's own thread copies the ring ``RATE`` times a second, in the loop's slack
  (``rig.live.view.Ring.cue``: just after the loop's cycle has appended its row), and hands the copy
  here, where the rows newer than the last update are decimated and sent on with the axes'
  states (``rig.view.states``) to the scope, which ``rig run --view`` keeps in the server's
  own process (``rig.view.process``). The recorder's files are not touched.
- ``TailFeed``: a thread that follows a run directory's ``samples.csv`` as the recorder flushes
  it (every 50 ms of run time), for ``rig view RUN_DIR`` beside a run in another process; the run
  has ended when its ``summary.json`` is there. It reads the files only.
"""

from __future__ import annotations

import bisect
import json
import logging
import os
import threading
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from rig.live.channels import Channel
from rig.view.meta import _TIMING, _json, meta_of, read_meta
from rig.view.scope import Scope, decimate

__all__ = ["RATE", "TAIL_BYTES", "RingFeed", "Sink", "TailFeed", "parse_lines"]

log = logging.getLogger(__name__)

RATE = 30.0  #: [1/s] updates of the live scope (at least 20 under load)
#: [s] a summary.json that does not parse for this long: the run ended without one
TORN_WAIT = 2.0
TAIL_BYTES = 4 << 20  #: of a run in progress's samples.csv read at the start (its last rows)


class Sink(Protocol):
    """Where the updates go: a ``Scope`` (in this process) or ``rig.view.process.PipeSink``."""

    def open(self, meta: dict[str, Any]) -> None:
        """A run begins: its description.

        Parameters
        ----------
        meta : dict[str, Any]
            The run's description.
        """

    def push(self, rows: np.ndarray, states: Mapping[str, Mapping[str, Any]] | None = None) -> None:
        """New rows and the axes' states.

        Parameters
        ----------
        rows : np.ndarray
            The rows, decimated.
        states : Mapping[str, Mapping[str, Any]] | None, optional
            Axis -> its state (None: unchanged).
        """

    def stop(self) -> None:
        """The run has ended."""


class RingFeed:
    """A LiveView backend feeding ``scope`` (a ``Sink``); the run's directory is ``output``/title
    (the recorder's), its description read from the files the recorder wrote at its start;
    ``states()`` gives the axes' states (``rig.view.states.state_probe``), once known.

    Parameters
    ----------
    scope : Sink
        What it feeds.
    output : str | Path
        The runs' folder.
    """

    def __init__(self, scope: Sink, output: str | Path) -> None:
        self.scope = scope
        self.output = Path(output)
        self.states: Callable[[], dict[str, dict[str, Any]]] | None = None
        self._after = -np.inf  #: [s] the time of the last row sent

    def open(self, channels: Sequence[Channel], title: str) -> None:
        """The run begins: its description to the scope.

        Parameters
        ----------
        channels : Sequence[Channel]
            The axes shown.
        title : str
            The run's name.
        """
        run_dir = self.output / title
        docs = _json(run_dir / "columns.json")
        columns = list(docs)
        while columns and columns[-1] in _TIMING:  # the stage durations are not in the ring's rows
            columns.pop()
        self.scope.open(meta_of(columns, docs, _json(run_dir / "config.json"), title))

    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        """The new rows to the scope.

        Parameters
        ----------
        rows : Sequence[Sequence[float]]
            The latest rows.
        final : bool, optional
            The run has ended.
        """
        start = bisect.bisect_right(rows, self._after, key=lambda r: r[0])
        new = np.array(rows[start:], dtype=float)
        if len(new):
            self._after = float(new[-1, 0])
        states = self.states() if self.states is not None else None
        self.scope.push(decimate(new) if len(new) else new, states)
        if final:
            self.scope.stop()

    def close(self) -> None:
        """Tell the scope the run has ended."""
        self.scope.stop()


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
