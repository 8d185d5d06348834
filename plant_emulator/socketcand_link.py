"""One socketcand client's connection: its bounded queue of lines out, its commands in, its socket.

The server's one I/O thread owns the socket (non-blocking) and everything here but ``put``.
Whoever has a frame for the client (the devices, under their lock; the I/O thread relaying
another client's frame) calls ``put``, which never blocks: a queue of ``depth`` lines that is
full dooms the client (a client that does not read is dropped, never waited for), and the I/O
thread is told (``dirty``) to send. ``send`` writes what is queued as far as the kernel takes
it; a client that takes nothing for ``send_timeout`` [s] is doomed too. The client's commands
wait in ``commands`` until the bus and the client's own queue (half of it for frames: a client
that sends faster than it reads is slowed down) have room for their effect.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import socket

import can

from plant_emulator.socketcand_protocol import MAX_COMMAND, CommandSplitter

__all__ = ["ClientLink", "check_limits"]

log = logging.getLogger(__name__)


def _peer(sock: socket.socket) -> str:
    try:
        host, port = sock.getpeername()[:2]
    except OSError:
        return "?"
    return f"{host}:{port}"


def check_limits(depth: int, send_timeout: float) -> None:
    """ValueError naming the value unless ``depth`` >= 2 lines and ``send_timeout`` > 0 s.

    Parameters
    ----------
    depth : int
        Lines a client may have waiting, >= 2.
    send_timeout : float
        [s] > 0.

    Raises
    ------
    ValueError
        If either is out of range (it named).
    """
    if depth < 2:
        raise ValueError(f"socketcand: queue depth {depth}: must be at least 2 lines")
    if not send_timeout > 0.0:
        raise ValueError(f"socketcand: send timeout {send_timeout} s: must be > 0")


class ClientLink:
    """See the module docstring; ``depth`` lines may wait, ``send_timeout`` [s] for the kernel
    to take any of them.

    Parameters
    ----------
    sock : socket.socket
        The client's socket.
    depth : int
        Lines that may wait.
    send_timeout : float
        [s] for the kernel to take any of them.
    """

    def __init__(self, sock: socket.socket, *, depth: int, send_timeout: float) -> None:
        check_limits(depth, send_timeout)
        self.sock = sock
        self.name = _peer(sock)
        self.depth = depth
        self.send_timeout = send_timeout
        self.lines: collections.deque[str] = collections.deque()  #: queued out, in order
        self.unsent = b""  #: taken from ``lines``, not yet taken by the kernel
        self.stuck_since: float | None = None  #: [s, monotonic] the kernel took nothing since
        self.commands: collections.deque[str] = collections.deque()  #: read, not yet done
        self.splitter = CommandSplitter(MAX_COMMAND)
        self.dirty = False  #: on the server's list of links with lines to send
        self.doomed: str | None = None  #: why it is to be dropped (put by any thread)
        self.closed = False
        self.eof = False  #: the client closed its side (a failed send is then no surprise)
        self.errors = 0  #: commands refused so far
        self.opened = False  #: ``< open BUS >`` done
        self.rawmode = False  #: ``< rawmode >`` done: the client gets every frame
        self.events = 0  #: the selector events it is registered for
        self.head: can.Message | None = None  #: its first command's frame, waiting for the bus
        self.head_key = (0, 0)  #: (arbitration rank, order it came to wait in) of ``head``

    def put(self, line: str) -> bool:
        """Queue ``line`` (ASCII); never blocks. False when the client was not waiting for it
        before (the caller tells the I/O thread); a full queue dooms the client.

        Parameters
        ----------
        line : str
            The line, ASCII.

        Returns
        -------
        bool
            The client was waiting for it before (else the caller tells the I/O thread).
        """
        if self.doomed is not None or self.closed:
            return True
        if len(self.lines) >= self.depth:
            self.doomed = f"{self.depth} lines waiting to be sent (is it reading?)"
            self.lines.clear()
        else:
            self.lines.append(line)
        if self.dirty:
            return True
        self.dirty = True
        return False

    @property
    def crowded(self) -> bool:
        """Half its queue taken: its commands wait (frames keep the other half)."""
        return len(self.lines) >= self.depth // 2 or len(self.unsent) > 0

    def send(self, now: float) -> bool:
        """Hand the kernel what is queued, as much as it takes now; True when all is taken.
        A client that took nothing for ``send_timeout`` [s], or whose socket failed, is doomed.

        Parameters
        ----------
        now : float
            [s] ``time.monotonic()``.

        Returns
        -------
        bool
            All is taken.
        """
        while True:
            if not self.unsent:  # what the kernel refused last time goes first, and alone
                taken = []
                with contextlib.suppress(IndexError):  # put() may clear the queue meanwhile
                    while self.lines:
                        taken.append(self.lines.popleft())
                if not taken:
                    self.stuck_since = None
                    return True
                self.unsent = "".join(taken).encode("ascii")
            try:
                sent = self.sock.send(self.unsent)
            except BlockingIOError:
                sent = 0
            except OSError as exc:
                self.eof = self.eof or isinstance(exc, (BrokenPipeError, ConnectionResetError))  # it left
                self.doomed = self.doomed or f"send failed: {exc}"
                self.unsent = b""
                return True
            self.unsent = self.unsent[sent:]
            if self.unsent:
                break
        if sent or self.stuck_since is None:
            self.stuck_since = now
        elif now - self.stuck_since > self.send_timeout:
            self.doomed = f"a line not taken within {self.send_timeout:g} s (is it reading?)"
        return False

    def close(self, reason: str | None, level: int = logging.WARNING) -> None:
        """Shut and close the socket (what is queued is not sent); ``reason`` logged.

        Parameters
        ----------
        reason : str | None
            Why, logged (None: nothing logged).
        level : int, optional
            Its logging level.
        """
        if self.closed:
            return
        self.closed = True
        self.lines.clear()
        if reason is not None:
            if self.eof and level > logging.INFO:
                level = logging.INFO  # it left first: a failed send is no surprise
            log.log(level, "socketcand: client %s dropped: %s", self.name, reason)
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()
