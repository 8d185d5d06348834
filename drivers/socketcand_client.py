"""The host's socketcand client: python-can's, with a bounded handshake and a lean frame path.

``SocketcandBus`` is python-can's ``SocketCanDaemonBus`` (its connect, greeting and
``< open CH >``/``< rawmode >`` handshake) with:

- the connect and the whole handshake bounded by one deadline: where nothing listens, a server
  accepts and never greets, or greets and then stalls, one ``CommunicationError`` names
  host:port and what did not come (python-can's retries for 10 s with a warning per try, then
  waits for each answer for ever); frames right behind the rawmode ``< ok >`` are kept
  (socketcand sends them on a busy bus; python-can's refuses them);
- a frame path of its own, because every frame of a cycle passes it (SYNC and RPDO out, the
  TPDOs in) and the host's SYNC-to-RPDO response is the sum of such paths: a send is one
  formatted line and one ``sendall``; a receive is one ``select`` and one ``recv`` for all the
  frames that came, parsed by ``parse_frames`` (python-can's client did a ``select``, a
  ``recv`` of at most 1 KiB, a ``TCP_QUICKACK`` system call and a string search per frame, and
  warned "Got incomplete message" whenever TCP cut a line, which is ordinary). Both sockets
  have ``TCP_NODELAY``, so no delayed acknowledgement holds a frame back;
- a server that closed the connection: each receive waits its timeout and returns nothing
  (said once), where python-can's returned at once for ever, a spin that at the receive
  thread's real-time priority starved the host's loop on its CPU;
- ``claim()``/``release()``: for a while only the claiming thread reads (the host loop during its
  cycles: it waits for the TPDOs answering its SYNC on the socket itself, not for a receive
  thread that reads them and then wakes it, two thread switches less per cycle); any other
  reader (python-can's notifier thread) is woken from its ``select``, parks at once and reads
  again after ``release``. Frames stay in the order they came.

Wire format (socketcand's rawmode): ``< send ID DLC B0 B1 ... >`` out (ID three hex digits, or
eight for an extended one; the bytes in hex), ``< frame ID SEC.USEC HEXDATA >`` in.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import math
import select
import socket
import threading
import time
from typing import Any

import can
from can.interfaces.socketcand import socketcand as python_can_socketcand

from drivers.errors import CommunicationError, brief

__all__ = ["SocketcandBus", "format_send", "install_bounded_connect", "parse_frames"]

log = logging.getLogger(__name__)

_CHUNK = 65536  #: [bytes] read at a time
_DONTWAIT = getattr(socket, "MSG_DONTWAIT", 0)  #: a recv that never blocks (where the system has it)
_ID_MAX = {False: 0x7FF, True: 0x1FFFFFFF}  #: the largest standard and extended identifiers
_LONGEST = 200  #: [characters] an unfinished line longer than this is not a frame: dropped

#: the deadline [time.monotonic() s] of the socketcand connection this thread is opening (None:
#: python-can's own connect, for whoever opens one without ``SocketcandBus``)
_opening = threading.local()
_plain_connect = python_can_socketcand.connect_to_server


def _connect(sock: socket.socket, host: str, port: int) -> None:
    """python-can's ``connect_to_server`` (retries for 10 s, a warning per try, then a blocking
    socket with no timeout) where this thread has no deadline; one try within it where it has."""
    deadline: float | None = getattr(_opening, "deadline", None)
    if deadline is None:
        _plain_connect(sock, host, port)  # type: ignore[no-untyped-call]
        return
    sock.settimeout(max(deadline - time.monotonic(), 1e-3))
    sock.connect((host, port))


def install_bounded_connect() -> None:
    """python-can's client connects through ``_connect`` (bounded where a deadline is set)."""
    if python_can_socketcand.connect_to_server is not _connect:
        python_can_socketcand.connect_to_server = _connect


def format_send(msg: can.Message) -> bytes:
    """``msg`` as socketcand's ``< send ID DLC B0 ... >`` line.

    Parameters
    ----------
    msg : can.Message
        The frame.

    Returns
    -------
    bytes
        The line, ASCII.
    """
    can_id = msg.arbitration_id
    ident = f"{can_id & 0x1FFFFFFF:08X}" if msg.is_extended_id else f"{can_id & 0x7FF:03X}"
    return f"< send {ident} {msg.dlc:X} {msg.data[: msg.dlc].hex(' ')} >".encode("ascii")


def parse_frames(text: str, channel: Any, out: collections.deque[can.Message]) -> str:
    """The ``< frame ID SEC.USEC HEXDATA >`` lines of ``text`` appended to ``out`` as received
    frames on ``channel``; the unfinished rest of ``text`` is returned (it waits for the next
    segment). A frame starts at the last ``< frame`` before its ``>``: a broken line costs only
    itself. A frame is a classic CAN frame: an id of 3 hex digits up to 7FF or 8 up to 1FFFFFFF,
    at most 8 data bytes, a finite time. Other lines (``< ok >``, ``< echo >``, a server's
    ``< error ... >``) and malformed ones are no frames: logged at debug.

    Parameters
    ----------
    text : str
        What the socket gave, after the rest of the last segment.
    channel : Any
        The channel the frames are stamped with.
    out : collections.deque[can.Message]
        Where the frames go.

    Returns
    -------
    str
        The unfinished rest of ``text``.
    """
    end = text.find(">")
    while end >= 0:
        line = text[:end]
        text = text[end + 1 :]
        start = line.rfind("< frame ")  # the last: an unfinished line before it is not this frame
        if start >= 0:
            words = line[start + 8 :].split()
            try:
                ident, stamp = words[0], float(words[1])
                data = bytes.fromhex(words[2]) if len(words) > 2 else b""
                can_id = int(ident, 16)
                if len(ident) not in (3, 8) or can_id > _ID_MAX[len(ident) == 8] or len(data) > 8:
                    raise ValueError("not a classic CAN frame")
                if not math.isfinite(stamp):
                    raise ValueError("not a time")
            except (ValueError, IndexError):
                log.debug("socketcand: not a frame: %r", line + ">")
            else:
                out.append(
                    can.Message(
                        timestamp=stamp,
                        arbitration_id=can_id,
                        data=data,
                        dlc=len(data),
                        is_extended_id=len(ident) == 8,
                        is_rx=True,
                        channel=channel,
                    )
                )
        elif line.strip():
            log.debug("socketcand: not a frame: %r", line + ">")
        end = text.find(">")
    if len(text) > _LONGEST:
        log.warning("socketcand: %d characters without a '>': not a frame, dropped", len(text))
        start = text.rfind("<")  # a frame that began at the end of it is kept
        return text[start:] if start >= 0 and len(text) - start <= _LONGEST else ""
    return text


class SocketcandBus(python_can_socketcand.SocketCanDaemonBus):
    """See the module docstring. ``timeout`` [s] bounds the connect and the handshake together.

    Parameters
    ----------
    channel : str
        The socketcand bus (``can0``).
    host, port
        The socketcand server.
    timeout : float
        [s] the connect and the handshake together.
    **kwargs : Any
        python-can's ``SocketCanDaemonBus`` arguments.

    Raises
    ------
    CommunicationError
        If it cannot connect or the handshake fails in time.
    """

    def __init__(self, channel: str, host: str, port: int, *, timeout: float, **kwargs: Any) -> None:
        self._deadline = time.monotonic() + timeout
        self._awaited = "the TCP connection"
        self._closed = False  #: the server closed the connection (``_recv_internal``)
        self._frames: collections.deque[can.Message] = collections.deque()
        self._rest = ""  #: an unfinished line, waiting for the rest
        self._owner: int | None = None  #: the thread that alone reads (``claim``), or None
        self._resume = threading.Event()  #: set while nobody has claimed the reading
        self._resume.set()
        self._parked = threading.Event()  #: another reader has parked since the last claim
        self._wake_r, self._wake_w = socket.socketpair()  #: wakes a reader in its select
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        install_bounded_connect()
        _opening.deadline = self._deadline
        try:
            super().__init__(channel, host, port, tcp_tune=True, **kwargs)  # type: ignore[no-untyped-call]
        except (OSError, can.CanError) as exc:
            self._wake_r.close()
            self._wake_w.close()
            self._is_shutdown = True  # never opened: nothing for BusABC.__del__ to complain of
            if hasattr(self, "_SocketCanDaemonBus__socket"):
                self._socket.close()
            raise CommunicationError(self._failure(host, port, timeout, exc)) from None
        finally:
            _opening.deadline = None
        self._socket.settimeout(None)

    @property
    def _socket(self) -> socket.socket:
        """python-can's socket (its name-mangled attribute)."""
        sock: socket.socket = getattr(self, "_SocketCanDaemonBus__socket")  # noqa: B009
        return sock

    def _expect_msg(self, msg: str) -> None:
        """``msg`` (``< hi >``, ``< ok >``) before the deadline, however TCP cuts it; what comes
        after it in the same read (frames right behind the rawmode ``< ok >``, which socketcand
        sends on a busy bus: SavvyCAN fixed the same in its pull request 495) is kept as frames
        received, where python-can's own would raise."""
        self._awaited = f"{msg!r}"
        sock, got = self._socket, ""
        while len(got) < len(msg) and msg.startswith(got):
            sock.settimeout(max(self._deadline - time.monotonic(), 1e-3))
            chunk = sock.recv(256).decode("ascii", errors="replace")
            if not chunk:
                break
            got += chunk
        if not got.startswith(msg):
            raise can.CanError(f"Expected '{msg}' got: '{got}'")
        self._rest = parse_frames(got[len(msg) :], self.channel, self._frames)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """``msg`` as one line, one ``sendall`` (``timeout``: ignored, as python-can's).

        Parameters
        ----------
        msg : can.Message
            The frame.
        timeout : float | None, optional
            Ignored.
        """
        self._socket.sendall(format_send(msg))

    def claim(self, *, others: bool = True) -> None:
        """From now on only the calling thread reads (until ``release``); with ``others`` (a
        notifier thread reads too), wait (at most 1 s) until it has parked.

        Parameters
        ----------
        others : bool, optional
            Another thread reads too: wait (at most 1 s) until it has parked.
        """
        self._parked.clear()
        self._resume.clear()
        self._owner = threading.get_ident()
        with contextlib.suppress(OSError):  # full: a wake is pending already
            self._wake_w.send(b"\0")
        if others and not self._parked.wait(1.0):
            log.warning(
                "%s: the bus's other reader did not park within 1 s: both read on (frames are "
                "handed on all the same, with a thread switch more)",
                self.channel_info,
            )

    def release(self) -> None:
        """Every thread may read again (the parked one goes on)."""
        self._owner = None
        self._resume.set()

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        """A frame already read, else one ``select`` (up to ``timeout`` [s]) and one ``recv`` of
        whatever came. A thread other than the one that claimed the reading (``claim``) parks
        instead, up to ``timeout``. Once the server has closed the connection: no frame after
        waiting ``timeout`` (said once; the next send meets the closed link: the host's safe
        stop)."""
        owner = self._owner
        if owner is not None and owner != threading.get_ident():
            self._parked.set()
            self._resume.wait(timeout)
            return None, False
        frames = self._frames
        if frames:
            return frames.popleft(), False
        if self._closed:
            time.sleep(1.0 if timeout is None else timeout)
            return None, False
        sock, wake = self._socket, self._wake_r
        try:
            ready, _, _ = select.select([sock, wake], [], [], timeout)
        except OSError as exc:
            raise can.CanError(f"Failed to receive: {exc}") from exc
        if wake in ready:
            with contextlib.suppress(OSError):
                wake.recv(64)
        if sock not in ready or self._owner not in (None, threading.get_ident()):
            return None, False  # (claimed meanwhile: the next call parks)
        self._read()
        return (frames.popleft() if frames else None), False

    def _read(self) -> None:
        """One ``recv`` of whatever the socket holds (not waiting), parsed into the frames read.
        The unfinished line is let go of until the parse: a read lost to a signal in between
        (the host loop reads here itself) drops the line it finished; the next read's tail
        cannot finish it instead (one frame's start, another's data)."""
        rest, self._rest = self._rest, ""
        try:
            chunk = self._socket.recv(_CHUNK, _DONTWAIT)
        except BlockingIOError:
            self._rest = rest
            return
        except OSError as exc:
            raise can.CanError(f"Failed to receive: {exc}") from exc
        if not chunk:
            self._closed = True
            log.warning("%s: the socketcand server closed the connection", self.channel_info)
            return
        self._rest = parse_frames(rest + chunk.decode("ascii", errors="replace"), self.channel, self._frames)

    def fill(self) -> int:
        """The frames that have come, ready for ``recv`` without a wait: those read and not yet
        taken, and those one read of the socket brings now (where it holds any). For the
        claiming thread: a drain of what has come takes this many, so a sender that never
        pauses cannot hold it for ever (``drivers.owned_receive.OwnedReceive``).

        Returns
        -------
        int
            Frames ready for ``recv`` without a wait.

        Raises
        ------
        CanError
            If the socket fails.
        """
        if not self._closed:
            try:
                ready, _, _ = select.select([self._socket], [], [], 0.0)
            except OSError as exc:
                raise can.CanError(f"Failed to receive: {exc}") from exc
            if ready:
                self._read()
        return len(self._frames)

    def shutdown(self) -> None:
        """python-can's (the socket closed), and the wake pair too."""
        super().shutdown()  # type: ignore[no-untyped-call]
        self._wake_r.close()
        self._wake_w.close()

    def _failure(self, host: str, port: int, timeout: float, exc: BaseException) -> str:
        where = f"{host}:{port}"
        if self._awaited == "the TCP connection":
            if isinstance(exc, TimeoutError):
                return f"cannot reach a socketcand server at {where}: no connection within {timeout:g} s"
            return f"cannot reach a socketcand server at {where}: {exc}"
        if isinstance(exc, TimeoutError):
            if self._awaited == "'< hi >'":
                return f"the socketcand server at {where} sent no greeting '< hi >' within {timeout:g} s"
            return (
                f"the socketcand server at {where} greeted, then sent no {self._awaited} within "
                f"{timeout:g} s of the connect (a stalled server?)"
            )
        got = brief(exc).split(" got: ", 1)[-1].strip("'") if isinstance(exc, can.CanError) else None
        if got == "":
            return f"the socketcand server at {where} closed the connection waiting for {self._awaited}"
        if self._awaited == "'< hi >'" and got is not None:
            return f"{where} is not a socketcand server: it sent {got[:40]!r}, not '< hi >'"
        return f"the socketcand server at {where}: waiting for {self._awaited}: {brief(exc)}"
