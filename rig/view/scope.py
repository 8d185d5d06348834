"""The live scope's state: written by one feeder thread, read by the server's event loop.

The feeder (``rig.view.feed``) gives it the run's description once (``open``), then at each
update the rows that are new, decimated for the screen (``decimate``: at most ``MOST`` rows an
update, each bucket as its minimum and maximum, so a chattering command keeps its band), and the
axes' states; at the end the run's summary (``finish``). Each update is encoded to JSON once,
here, and kept for ``KEEP`` seconds of the run: a browser that connects gets that history
(decimated again to ``HISTORY`` rows) and then every update after it. A lock guards the lists;
nothing here waits for a browser.
"""

from __future__ import annotations

import collections
import json
import math
import threading
from collections.abc import Mapping
from typing import Any

import numpy as np

from rig.host.readback import Envelope

__all__ = ["HISTORY", "KEEP", "MOST", "Scope", "decimate", "rows_json"]

MOST = 200  #: rows an update sends at most (a 0.1 ms period at 25 updates/s: 400 rows, as 200)
KEEP = 30.0  #: [s] of the run kept for a browser that connects later
HISTORY = 4000  #: rows of that history sent at most


def decimate(rows: np.ndarray, most: int = MOST) -> np.ndarray:
    """``rows`` (time first) as at most ``most`` rows: themselves, or the minimum and maximum of
    each column over buckets of consecutive rows (``rig.host.readback.Envelope``).

    Parameters
    ----------
    rows : np.ndarray
        Time first.
    most : int, optional
        Rows at most.

    Returns
    -------
    np.ndarray
        The rows.
    """
    if len(rows) <= most:
        return rows
    envelope = Envelope(len(rows), rows.shape[1], max(1, most // 2))
    envelope.add(rows)
    return envelope.rows()


def rows_json(rows: np.ndarray) -> str:
    """``rows`` as a JSON array of arrays, NaN and infinities as null.

    Parameters
    ----------
    rows : np.ndarray
        The rows.

    Returns
    -------
    str
        JSON.
    """
    clean = np.where(np.isfinite(rows), rows, np.nan)
    return json.dumps(clean.tolist()).replace("NaN", "null")


class Scope:
    """See the module docstring. ``seq`` counts the updates; ``ended`` is the summary once the run
    ended (``{}`` while it goes on).

    Parameters
    ----------
    keep : float, optional
        [s] of history kept.
    """

    def __init__(self, keep: float = KEEP) -> None:
        self.keep = keep
        self._lock = threading.Lock()
        self.meta: dict[str, Any] | None = None
        self.seq = 0
        self._updates: collections.deque[tuple[int, float, np.ndarray, str]] = collections.deque()
        self.states: dict[str, dict[str, Any]] = {}
        self.states_json = "{}"
        self.ended: dict[str, Any] = {}
        self.stopped = False  #: the cycles ended (the summary may follow)
        self.done = threading.Event()  #: the summary is in
        self.watchers = 0  #: browsers connected (the server's event loop counts them)

    def open(self, meta: dict[str, Any]) -> None:
        """A run begins: its description, the history cleared.

        Parameters
        ----------
        meta : dict[str, Any]
            The run's description.
        """
        with self._lock:
            self.meta = meta

    def push(self, rows: np.ndarray, states: Mapping[str, Mapping[str, Any]] | None = None) -> None:
        """An update: ``rows`` (already decimated) and the axes' ``states``.

        Parameters
        ----------
        rows : np.ndarray
            The rows, decimated.
        states : Mapping[str, Mapping[str, Any]] | None, optional
            Axis -> its state.
        """
        text = rows_json(rows) if len(rows) else ""
        states_text = json.dumps(states) if states is not None else None
        with self._lock:
            if states_text is not None:
                self.states, self.states_json = {k: dict(v) for k, v in (states or {}).items()}, states_text
            if not len(rows) and states_text is None:
                return
            self.seq += 1
            last = float(rows[-1, 0]) if len(rows) else (self._updates[-1][1] if self._updates else 0.0)
            self._updates.append((self.seq, last, rows, text))
            while self._updates and self._updates[0][1] < last - self.keep:
                self._updates.popleft()

    def stop(self) -> None:
        """The cycles ended."""
        with self._lock:
            self.stopped = True

    def finish(self, summary: Mapping[str, Any]) -> None:
        """The run's summary (its stop reason, figures): sent to every browser, then it is done.

        Parameters
        ----------
        summary : Mapping[str, Any]
            The run's summary.
        """
        clean = {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in summary.items()
        }
        with self._lock:
            self.ended = clean
            self.stopped = True
        self.done.set()

    def since(self, seq: int, meta: bool = False) -> tuple[int, str | None]:
        """(the latest update's number, one JSON message with the rows of the updates after
        ``seq`` and the states, and with ``meta`` the run's description, or None when there is
        nothing new).

        Parameters
        ----------
        seq : int
            The last update a browser has.
        meta : bool, optional
            Include the run's description.

        Returns
        -------
        tuple[int, str | None]
            (the latest number, the message or None).
        """
        with self._lock:
            if seq >= self.seq:
                return self.seq, None
            parts = [text for n, _, _, text in self._updates if n > seq and text]
            latest, states, described = self.seq, self.states_json, self.meta
        rows = "[" + ",".join(p[1:-1] for p in parts if p != "[]") + "]"
        head = f'"meta":{json.dumps(described)},' if meta and described is not None else ""
        return latest, f'{{"type":"rows",{head}"rows":{rows},"states":{states}}}'

    def hello(self) -> tuple[int, str]:
        """(the latest update's number, the message a browser gets first: the run's description,
        the kept history decimated to ``HISTORY`` rows, the states, and the summary if it ended).

        Returns
        -------
        tuple[int, str]
            (the latest number, the message).
        """
        with self._lock:
            chunks = [rows for _, _, rows, _ in self._updates if len(rows)]
            meta, seq, states = self.meta, self.seq, self.states
            ended, stopped = self.ended, self.stopped
        history = decimate(np.concatenate(chunks), HISTORY) if chunks else np.empty((0, 0))
        doc = {"type": "hello", "meta": meta, "states": states, "stopped": stopped, "summary": ended or None}
        body = json.dumps(doc)[:-1]
        return seq, f'{body},"rows":{rows_json(history) if len(history) else "[]"}}}'

    def end_message(self) -> str | None:
        """The end's message once the summary is in (None before).

        Returns
        -------
        str | None
            The message, or None.
        """
        if not self.done.is_set():  # a run that ended without a summary still ends: {}
            return None
        with self._lock:
            return json.dumps({"type": "end", "summary": self.ended})
