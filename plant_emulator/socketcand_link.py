"""One socketcand client's connection: a bounded queue of outgoing lines and the thread that writes them.

Whoever has a frame for the client (the devices, under their lock; another client's
reader) calls ``put``, which never blocks. The client's own reader queues its answers
with ``reply``, which waits while the queue is half full: a client that sends faster
than it reads is slowed down, and frames keep half the queue. The writer thread sends
the lines in order, each within ``send_timeout`` [s]. A client whose queue is full,
or whose send times out or fails, is dropped: nothing more is queued or sent, the
socket is shut (its reader's ``recv`` returns), and the reason is logged once.
"""

from __future__ import annotations

import collections
import logging
import socket
import threading

__all__ = ["ClientLink", "check_limits"]

log = logging.getLogger(__name__)


def _peer(sock: socket.socket) -> str:
    try:
        host, port = sock.getpeername()[:2]
    except OSError:
        return "?"
    return f"{host}:{port}"


def check_limits(depth: int, send_timeout: float) -> None:
    """ValueError naming the value unless ``depth`` >= 2 lines and ``send_timeout`` > 0 s."""
    if depth < 2:
        raise ValueError(f"socketcand: queue depth {depth}: must be at least 2 lines")
    if not send_timeout > 0.0:
        raise ValueError(f"socketcand: send timeout {send_timeout} s: must be > 0")


class ClientLink:
    """See the module docstring; ``depth`` lines may wait, ``send_timeout`` [s] per line."""

    def __init__(self, sock: socket.socket, *, depth: int, send_timeout: float) -> None:
        check_limits(depth, send_timeout)
        self.sock = sock
        self.name = _peer(sock)
        self.depth = depth
        self.send_timeout = send_timeout
        self.closed = threading.Event()  #: set once dropped or finished: nothing more is sent
        self.eof = False  #: the client closed its side (a failed send is then no surprise)
        self.errors = 0  #: commands refused so far
        self.opened = False  #: ``< open BUS >`` done
        self.rawmode = False  #: ``< rawmode >`` done: the client gets every frame
        self._lines: collections.deque[str] = collections.deque()
        self._changed = threading.Condition()  #: guards ``_lines`` and ``_ending``
        self._ending = False  #: finish(): send what is queued, then stop
        self._logged = False
        sock.settimeout(send_timeout)  # the reader's recv wakes this often too
        name = f"socketcand-writer {self.name}"
        self._writer = threading.Thread(target=self._write, name=name, daemon=True)
        self._writer.start()

    def put(self, line: str) -> None:
        """Queue a frame's ``line`` (ASCII); a full queue drops the client. Never blocks."""
        with self._changed:
            if self.closed.is_set():
                return
            room = len(self._lines) < self.depth
            if room:
                self._lines.append(line)
                self._changed.notify_all()
        if not room:
            self.drop(f"{self.depth} lines waiting to be sent (is it reading?)")

    def reply(self, line: str) -> None:
        """Queue an answer to the client's own command (from its reader, no lock held).

        Waits up to ``send_timeout`` [s] while the queue is half full, then drops the client.
        """
        with self._changed:
            room = self._changed.wait_for(
                lambda: self.closed.is_set() or len(self._lines) < self.depth // 2, self.send_timeout
            )
            if self.closed.is_set():
                return
            if room:
                self._lines.append(line)
                self._changed.notify_all()
        if not room:
            self.drop(f"answers not taken within {self.send_timeout:g} s (is it reading?)")

    def drop(self, reason: str, level: int = logging.WARNING) -> None:
        """Stop now: the lines still queued are not sent, the socket is shut; ``reason`` logged once."""
        with self._changed:
            if self.closed.is_set():
                return
            self.closed.set()
            self._lines.clear()
            self._changed.notify_all()
        self._log(reason, level)
        self._shut()

    def finish(self, reason: str | None = None) -> None:
        """End of the connection: the lines queued so far go out, then the socket is shut.

        ``reason`` (the client is dropped for it) is logged once. Waits for the writer at
        most ``send_timeout`` [s] plus one second, then drops the client.
        """
        if reason is not None:
            self._log(reason, logging.WARNING)
        with self._changed:
            self._ending = True
            self._changed.notify_all()
        self._writer.join(self.send_timeout + 1.0)
        if self._writer.is_alive():
            self.drop(f"queued lines not sent within {self.send_timeout + 1.0:g} s of its leaving")
        self.closed.set()
        self._shut()

    def _log(self, reason: str, level: int) -> None:
        with self._changed:
            if self._logged:
                return
            self._logged = True
        log.log(level, "socketcand: client %s dropped: %s", self.name, reason)

    def _shut(self) -> None:
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass  # already shut, or never connected

    def _next(self) -> str | None:
        """The next line to send; None: stop."""
        with self._changed:
            self._changed.wait_for(lambda: self._lines or self._ending or self.closed.is_set())
            if self.closed.is_set() or not self._lines:
                return None
            line = self._lines.popleft()
            self._changed.notify_all()  # room for ``reply``
            return line

    def _write(self) -> None:
        while (line := self._next()) is not None:
            try:
                self.sock.sendall(line.encode("ascii"))
            except TimeoutError:
                self.drop(f"a line not taken within {self.send_timeout:g} s (is it reading?)")
                return
            except OSError as exc:
                self.drop(f"send failed: {exc}", logging.INFO if self.eof else logging.WARNING)
                return
