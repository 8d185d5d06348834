"""Stop requests from the operating system: SIGINT, SIGTERM and SIGHUP become the one safe stop.

``StopRequests`` (one per session, installed from the main thread; the command line installs
one more for the whole command, ``rig.cli.main``) turns the first of these signals into
``StopRequested``, raised where the main thread is; it is a ``KeyboardInterrupt``, so every
path that brings the drives to rest on Ctrl-C does so for each of them. Once the stop has
begun (``stopping()``), or once this process has taken a stop signal (``forget()`` starts
afresh), further signals are logged and ignored: a second Ctrl-C in quick succession cannot
cut the drives' ramps, the disable or the recorder's close. Inside ``held`` (a cycle's row and
its count) the first signal waits for the section's end, so the rows on disk and the cycles
counted agree. A signal ignored when the handlers are installed stays ignored: its owner chose
that (``nohup`` for SIGHUP; a sweep's worker leaves Ctrl-C to its client); ``rig.cli.main``
turns SIGINT and SIGTERM back on, whatever the parent set. ``taken`` is the first stop signal
that came while the handlers were installed: a session passes it on once it has closed
(``rig.host.session``), so a study of many runs ends with the run it cut short.
SIGKILL cannot be caught: then the drive's own supervision (its heartbeat consumer 0x1016
and 0x6007) stops it.
"""

from __future__ import annotations

import logging
import signal
import threading
from types import FrameType
from typing import Any

__all__ = ["SIGNALS", "StopRequested", "StopRequests", "forget", "taken"]

log = logging.getLogger(__name__)

#: the signals that ask for a stop, and the words for the summary
SIGNALS = {
    signal.SIGINT: "Ctrl-C (SIGINT)",
    signal.SIGTERM: "SIGTERM (terminate)",
    signal.SIGHUP: "SIGHUP (hang-up)",
}

_TAKEN: list[int] = []  #: the stop signals this process took since ``forget()``


def forget() -> None:
    """A new command: the stop signals taken before are forgotten (``rig.cli.main`` in a test)."""
    _TAKEN.clear()


def taken() -> StopRequested | None:
    """The first stop signal this process took since ``forget()``, as a request.

    Returns
    -------
    StopRequested | None
        The request (None: no signal taken).
    """
    return StopRequested(_words(_TAKEN[0]), _TAKEN[0]) if _TAKEN else None


def _words(signum: int) -> str:
    return SIGNALS.get(signal.Signals(signum), signal.Signals(signum).name)


class StopRequested(KeyboardInterrupt):
    """A stop was asked for; passed on after a command's drives were brought to rest.

    Parameters
    ----------
    reason : str
        The words naming it.
    signum : int | None
        The signal (None: asked otherwise, a sweep point's time-out).
    confirmed : bool | None
        The drives' stop: True at rest and disabled; False not confirmed, they may still be moving;
        None nothing was moving.
    kept : str | None
        Where the work done so far is.
    """

    def __init__(
        self,
        reason: str,
        signum: int | None = None,
        *,
        confirmed: bool | None = None,
        kept: str | None = None,
    ) -> None:
        super().__init__(reason)
        self.reason = reason
        self.signum = signum
        self.confirmed = confirmed
        self.kept = kept

    def after(self, *, confirmed: bool | None, kept: str | None) -> StopRequested:
        """This request, passed on once a stop it began has ended.

        Parameters
        ----------
        confirmed : bool | None
            The drives' stop (as the class's).
        kept : str | None
            Where the work done so far is.

        Returns
        -------
        StopRequested
            A new request with the same reason and signal.
        """
        return StopRequested(self.reason, self.signum, confirmed=confirmed, kept=kept)


def stop_reason(exc: KeyboardInterrupt) -> str:
    """The words for a KeyboardInterrupt: the signal's, or Ctrl-C."""
    return exc.reason if isinstance(exc, StopRequested) else "Ctrl-C"


class StopRequests:
    """The session's signal handlers (module docstring).

    ``install()`` the handlers (a no-op outside the main thread), ``stopping()`` once the stop has
    begun, ``restore()`` the previous handlers (idempotent), ``pass_on()`` the stop signal
    ``taken`` (the first that came while installed).

    Parameters
    ----------
    doing : str | None
        Logged with the first signal (None: nothing).
    """

    def __init__(self, doing: str | None = "stopping the drives") -> None:
        self._previous: dict[int, Any] = {}
        self._armed = False
        self._holding = False
        self._pending: str | None = None
        self.doing = doing
        self.taken: StopRequested | None = None
        self.held = _Held(self)  #: ``with requests.held:`` a signal inside raises at its end

    def install(self) -> None:
        """Install the handlers, from the main thread; a signal ignored now stays ignored."""
        if threading.current_thread() is not threading.main_thread() or self._previous:
            return
        for sig in SIGNALS:
            if signal.getsignal(sig) is not signal.SIG_IGN:
                self._previous[sig] = signal.signal(sig, self._on_signal)
        self._armed = True

    def stopping(self) -> None:
        """The stop has begun: later signals do not interrupt it."""
        self._armed = False

    def restore(self) -> None:
        """The handlers as they were before ``install`` (idempotent)."""
        previous, self._previous = self._previous, {}
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        self._armed = False

    def pass_on(self, confirmed: bool | None, kept: object = None) -> None:
        """Raise the stop signal taken, if any, once the stop it began has ended.

        Parameters
        ----------
        confirmed : bool | None
            The drives' stop (``StopRequested``'s).
        kept : object
            Where the work done so far is (None: nowhere).

        Raises
        ------
        StopRequested
            The signal taken, with ``confirmed`` and ``kept``.
        """
        if self.taken is not None:
            raise self.taken.after(confirmed=confirmed, kept=None if kept is None else str(kept))

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        reason = _words(signum)
        first = not _TAKEN
        _TAKEN.append(signum)
        if self.taken is None:
            self.taken = StopRequested(reason, signum)
        if self._armed and first:
            self._armed = False
            if self.doing:
                log.warning("%s: %s", reason, self.doing)
            if self._holding:  # a cycle's record is being written: the stop comes at its end
                self._pending = reason
                return
            raise StopRequested(reason, signum)
        log.warning("%s while stopping: the stop goes on", reason)


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
            raise StopRequested(reason, r.taken.signum if r.taken else None)
