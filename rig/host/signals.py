"""Stop requests from the operating system: SIGINT, SIGTERM and SIGHUP become the one safe stop.

``StopRequests`` (one per session, installed from the main thread) turns the first of
these signals into ``StopRequested``, raised where the main thread is; it is a
``KeyboardInterrupt``, so every path that brings the drives to rest on Ctrl-C does so
for each of them. Once the stop has begun (``stopping()``), further signals are logged
and ignored: a second Ctrl-C in quick succession cannot cut the drives' ramps, the
disable or the recorder's close. Inside ``held`` (a cycle's row and its count) the first
signal waits for the section's end, so the rows on disk and the cycles counted agree.
SIGKILL cannot be caught: then the drive's own supervision (its heartbeat consumer 0x1016
and 0x6007) stops it.
"""

from __future__ import annotations

import logging
import signal
import threading
from types import FrameType
from typing import Any

__all__ = ["StopRequested", "StopRequests"]

log = logging.getLogger(__name__)

#: the signals that ask for a stop, and the words for the summary
SIGNALS = {
    signal.SIGINT: "Ctrl-C (SIGINT)",
    signal.SIGTERM: "SIGTERM (terminate)",
    signal.SIGHUP: "SIGHUP (hang-up)",
}


class StopRequested(KeyboardInterrupt):
    """A stop signal arrived; ``reason`` names it."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def stop_reason(exc: KeyboardInterrupt) -> str:
    """The words for a KeyboardInterrupt: the signal's, or Ctrl-C."""
    return exc.reason if isinstance(exc, StopRequested) else "Ctrl-C"


class StopRequests:
    """``install()`` the handlers (a no-op outside the main thread), ``stopping()`` once the stop
    has begun, ``restore()`` the previous handlers (idempotent)."""

    def __init__(self) -> None:
        self._previous: dict[int, Any] = {}
        self._armed = False
        self._holding = False
        self._pending: str | None = None
        self.held = _Held(self)  #: ``with requests.held:`` a signal inside raises at its end

    def install(self) -> None:
        if threading.current_thread() is not threading.main_thread() or self._previous:
            return
        for sig in SIGNALS:
            self._previous[sig] = signal.signal(sig, self._on_signal)
        self._armed = True

    def stopping(self) -> None:
        """The stop has begun: later signals do not interrupt it."""
        self._armed = False

    def restore(self) -> None:
        previous, self._previous = self._previous, {}
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        self._armed = False

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        reason = SIGNALS.get(signal.Signals(signum), signal.Signals(signum).name)
        if self._armed:
            self._armed = False
            log.warning("%s: stopping the drives", reason)
            if self._holding:  # a cycle's record is being written: the stop comes at its end
                self._pending = reason
                return
            raise StopRequested(reason)
        log.warning("%s while stopping: the stop goes on (the drives' ramps, then the recorder)", reason)


class _Held:
    """The section a stop request may not cut (a cycle's row and its count): a signal in it
    raises ``StopRequested`` when it ends, unless an exception already ends it."""

    def __init__(self, requests: StopRequests) -> None:
        self.requests = requests

    def __enter__(self) -> None:
        self.requests._holding = True

    def __exit__(self, kind: type[BaseException] | None, *rest: Any) -> None:
        r = self.requests
        r._holding = False
        reason, r._pending = r._pending, None
        if reason is not None and kind is None:
            raise StopRequested(reason)
