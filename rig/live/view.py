"""The live view's thread: the latest rows of the run, drawn a few times a second by a backend.

The control loop's only part is the recorder's: ``Recorder.sample`` appends each row it has
written to ``LiveView.rows``, a ``Ring`` (a ``collections.deque`` with a ``maxlen``: an O(1)
append that takes no lock and never waits). The viewer thread copies the deque (one C call under
the GIL), hands the copy to its backend at ``rate`` [Hz], and at the stop draws the last rows
once more and closes the backend. It draws in the loop's slack: after its pause it waits for the
next row (``Ring.cue``), which the loop appends at the end of its cycle, just before it sleeps to
the next period, so the viewer's work under the GIL falls where the loop does not need it. An
exception in a backend is logged once and ends the viewer; the run goes on.

``open_live(mode)`` picks the backend for ``--live``: ``"window"`` (a matplotlib window in a
process of its own, ``rig.live.window``), ``"terminal"`` (``rig.live.terminal``) or
``"auto"`` (the window where matplotlib and a display are there, else the terminal).
"""

from __future__ import annotations

import collections
import importlib.util
import logging
import os
import sys
import threading
from collections.abc import Sequence

from rig.live.backend import Backend, LiveUnavailable
from rig.live.channels import Channel

__all__ = ["MODES", "Backend", "LiveUnavailable", "LiveView", "Ring", "open_live", "window_problem"]

log = logging.getLogger(__name__)

MODES = ("auto", "terminal", "window")


class Ring(collections.deque[Sequence[float]]):
    """The rows the recorder appends, the latest ``keep``; ``cue()`` arms it, and the next append
    sets ``ready`` (the loop's cycle has just ended: its slack begins).

    Parameters
    ----------
    keep : int
        Rows kept.
    """

    def __init__(self, keep: int) -> None:
        super().__init__(maxlen=keep)
        self.ready = threading.Event()
        self.armed = False

    def append(self, row: Sequence[float]) -> None:
        """Append ``row`` (the loop's, once a cycle); set ``ready`` if cued.

        Parameters
        ----------
        row : Sequence[float]
            The row.
        """
        super().append(row)
        if self.armed:
            self.armed = False
            self.ready.set()

    def cue(self, timeout: float) -> bool:
        """Wait for the next row, at most ``timeout`` [s].

        Parameters
        ----------
        timeout : float
            [s] at most.

        Returns
        -------
        bool
            A row came.
        """
        self.ready.clear()
        self.armed = True
        return self.ready.wait(timeout)


class LiveView:
    """``backend`` fed from ``rows`` (the recorder appends) by a thread at ``rate`` [Hz].

    Parameters
    ----------
    backend : Backend
        What draws.
    rate : float, optional
        [Hz] of drawing.
    keep : int, optional
        Rows kept.
    join_timeout : float, optional
        [s] to wait for the drawing thread at the end.
    """

    def __init__(self, backend: Backend, *, rate: float = 4.0, keep: int = 4096, join_timeout: float = 2.0):
        self.backend = backend
        self.every = 1.0 / rate  #: [s] between two draws
        self.rows = Ring(keep)
        self.join_timeout = join_timeout  #: [s] the stop waits for the thread, then leaves it
        self.failed: str | None = None  #: why the viewer stopped early
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._closed = False

    def start(self, channels: Sequence[Channel], title: str) -> None:
        """Start drawing ``channels`` of the rows to come under ``title`` (the run's name).

        Parameters
        ----------
        channels : Sequence[Channel]
            The axes shown.
        title : str
            The run's name.
        """
        self._thread = threading.Thread(
            target=self._run, args=(list(channels), title), name="rig-live", daemon=True
        )
        self._thread.start()

    @property
    def thread(self) -> threading.Thread | None:
        """The drawing thread (None before ``start``)."""
        return self._thread

    def snapshot(self) -> list[Sequence[float]]:
        """The latest rows, oldest first (a copy the loop may append past).

        Returns
        -------
        list[Sequence[float]]
            The latest rows, oldest first.
        """
        for _ in range(3):
            try:
                return list(self.rows)
            except RuntimeError:  # "deque mutated during iteration": only without the GIL
                continue
        return []

    def _run(self, channels: list[Channel], title: str) -> None:
        try:
            self.backend.open(channels, title)
            final = False
            while not final:  # the first draw at once, the last one after the stop
                final = self._stop.is_set()
                self.backend.draw(self.snapshot(), final)
                if not final and not self._stop.wait(self.every):
                    self.rows.cue(self.every)  # the next draw in the loop's slack
        except Exception as exc:  # never into the run: logged once, the viewer ends
            self.failed = f"{type(exc).__name__}: {exc}" if not isinstance(exc, LiveUnavailable) else str(exc)
            log.warning("live view stopped: %s (the run goes on)", self.failed)
        finally:
            self._close_backend()

    def _close_backend(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.backend.close()
        except Exception as exc:
            log.debug("live view not closed cleanly: %s", exc)

    def stop(self) -> None:
        """Draw the last rows, close the backend; waits at most ``join_timeout`` [s] for the thread
        (a backend that hangs is left to end with the process). Safe to call twice or unstarted."""
        self._stop.set()
        thread = self._thread
        if thread is None:
            self._close_backend()
            return
        thread.join(self.join_timeout)
        if thread.is_alive():
            log.warning(
                "the live view did not stop within %g s; left to end with the process", self.join_timeout
            )


def window_problem() -> str | None:
    """Why a matplotlib window cannot open here (None: it may): no matplotlib, or no display.

    Returns
    -------
    str | None
        Why not, or None.
    """
    if importlib.util.find_spec("matplotlib") is None:
        return "matplotlib is not installed (pip install matplotlib)"
    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")) and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        return "no display (DISPLAY and WAYLAND_DISPLAY are not set)"
    return None


def open_live(mode: str) -> LiveView:
    """The live view of ``mode`` (``MODES``), its backend ready; LiveUnavailable (saying why) when
    ``"window"`` cannot open. ``"auto"`` falls back to the terminal strip.

    Parameters
    ----------
    mode : str
        One of ``MODES``.

    Returns
    -------
    LiveView
        The live view.

    Raises
    ------
    LiveUnavailable
        If ``"window"`` cannot open (why said).
    """
    if mode not in MODES:
        raise LiveUnavailable(f"unknown mode {mode!r} (one of {', '.join(MODES)})")
    if mode != "terminal":
        problem = window_problem()
        if problem is None:
            from rig.live.window import WindowBackend

            try:
                return LiveView(WindowBackend())
            except LiveUnavailable as exc:
                if mode == "window":
                    raise
                log.warning("live view: no window (%s); the terminal strip instead", exc)
        elif mode == "window":
            raise LiveUnavailable(problem)
    from rig.live.terminal import TerminalStrip

    return LiveView(TerminalStrip())
