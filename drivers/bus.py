"""Opening a CAN bus from configuration.

``open_bus`` wraps ``can.Bus`` with ``ignore_config=True``, so nothing is read
from ``~/.canrc`` or ``CAN_*`` environment variables by surprise, and turns a
failure into ``CommunicationError`` naming the interface and channel.
``ReceiveWatch`` keeps python-can's receive thread from dying with a traceback when the
bus goes away (a socketcand link reset, an interface down): the error is logged once and
kept in the notifier's ``exception``, where the axes' supervision finds it.
python-can's socketcand client warns "Got incomplete message" whenever a TCP segment ends
inside a frame, which is ordinary TCP; that line is demoted to debug (``_Fragments``). Its
connect retries for 10 s (a warning per try) and its handshake waits for each answer for ever;
``open_bus`` opens it as ``_Socketcand``, python-can's client with the connect and the whole
handshake (``< hi >``, then ``< open CH >`` and ``< rawmode >`` answered ``< ok >``) bounded by
``HANDSHAKE`` (3 s) together: where nothing listens, or a server accepts and never greets, or
greets and then stalls, one line names host:port and what did not come. An interface
python-can does not know is a ``ConfigError`` naming the known ones (``check_interface``).
"""

from __future__ import annotations

import logging
import select
import socket
import threading
import time
from typing import Any

import can
from can.interfaces.socketcand import socketcand as socketcand_client

from drivers.errors import CommunicationError, ConfigError

__all__ = ["ReceiveWatch", "brief", "check_interface", "open_bus", "scan_command"]

log = logging.getLogger(__name__)


def brief(exc: BaseException) -> str:
    """An exception's words without the traceback text python-can puts in some of them."""
    return str(exc).split("Traceback (most recent call last)")[0].strip()


class ReceiveWatch(can.Listener):
    """A notifier listener that handles receive errors: logged once, then the receive thread
    retries every ``pause`` [s] (not a busy loop) until it is stopped."""

    def __init__(self, pause: float = 0.05) -> None:
        self.pause = pause
        self.error: Exception | None = None

    def on_message_received(self, msg: can.Message) -> None:
        """Frames are for the other listeners."""

    def on_error(self, exc: Exception) -> None:
        if self.error is None:
            self.error = exc
            log.error("the bus is lost: %s", brief(exc))
        time.sleep(self.pause)


class _Fragments(logging.Filter):
    """Demotes python-can socketcand's warning for a frame split across TCP segments (the rest
    comes in the next segment: nothing is lost) to debug."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno == logging.WARNING and record.getMessage().startswith("Got incomplete message"):
            record.levelno, record.levelname = logging.DEBUG, "DEBUG"
            return logging.getLogger(record.name).isEnabledFor(logging.DEBUG)
        return True


_SOCKETCAND_LOG = logging.getLogger("can.interfaces.socketcand.socketcand")
SOCKETCAND_PORT = 29536  #: python-can's and socketcand's default port
HANDSHAKE = 3.0  #: [s] a socketcand connection's connect, greeting, open and rawmode, all together

#: the deadline [time.monotonic() s] of the socketcand connection this thread is opening (None:
#: python-can's own connect, for whoever opens one without ``open_bus``)
_opening = threading.local()
_plain_connect = socketcand_client.connect_to_server


def _connect(sock: socket.socket, host: str, port: int) -> None:
    """python-can's ``connect_to_server`` (retries for 10 s, a warning per try, then a blocking
    socket with no timeout) where this thread has no deadline; one try within it where it has."""
    deadline: float | None = getattr(_opening, "deadline", None)
    if deadline is None:
        _plain_connect(sock, host, port)  # type: ignore[no-untyped-call]
        return
    sock.settimeout(max(deadline - time.monotonic(), 1e-3))
    sock.connect((host, port))


class _Socketcand(socketcand_client.SocketCanDaemonBus):
    """python-can's socketcand client with its connect and handshake (``< hi >``, ``< open CH >``
    and ``< rawmode >``, each answered) bounded by one deadline ``timeout`` [s] from now: a server
    that does not answer, or stalls after any answer, is a CommunicationError naming host:port
    and what did not come. Once open, the socket blocks as python-can's does."""

    def __init__(self, channel: str, host: str, port: int, *, timeout: float, **kwargs: Any) -> None:
        self._deadline = time.monotonic() + timeout
        self._awaited = "the TCP connection"
        self._closed = False  #: the server closed the connection (``_recv_internal``)
        _opening.deadline = self._deadline
        try:
            super().__init__(channel, host, port, **kwargs)  # type: ignore[no-untyped-call]
        except (OSError, can.CanError) as exc:
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
        self._keep(got[len(msg) :])

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        """python-can's, but once the server has closed the connection, no frame after waiting
        ``timeout`` (said once): python-can's reads the end-of-file as no frame and selects again
        at once, a spin that at the real-time priority of the receive thread (``rig.host.realtime``)
        starves the loop on its CPU. The next send meets the closed link (the host's safe stop)."""
        if self._closed:
            time.sleep(1.0 if timeout is None else timeout)
            return None, False
        if not getattr(self, "_SocketCanDaemonBus__message_buffer"):  # noqa: B009
            sock = self._socket
            ready, _, _ = select.select([sock], [], [], timeout)
            if not ready:
                return None, False
            try:
                peek = sock.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT)
            except BlockingIOError:
                peek = b"?"
            except OSError as exc:
                raise can.CanError(f"Failed to receive: {exc}") from exc
            if not peek:
                self._closed = True
                log.warning("%s: the socketcand server closed the connection", self.channel_info)
                return None, False
            timeout = 0.0
        message: tuple[can.Message | None, bool] = super()._recv_internal(timeout)  # type: ignore[no-untyped-call]
        return message

    def _keep(self, text: str) -> None:
        """Frames in ``text`` (socketcand's ``< frame ... >``) queued as received; a cut one
        waits in python-can's receive buffer for the rest."""
        messages = getattr(self, "_SocketCanDaemonBus__message_buffer")  # noqa: B009
        while (end := text.find(">")) >= 0:
            start = text.find("<")
            part, text = text[start : end + 1], text[end + 1 :]
            if start < 0 or start > end:
                continue
            try:
                msg = socketcand_client.convert_ascii_message_to_can_message(part)
            except (ValueError, IndexError):  # python-can's parser on a malformed line
                log.debug("socketcand: not a frame: %r", part)
                continue
            if msg is not None:
                msg.channel = self.channel
                messages.append(msg)
        setattr(self, "_SocketCanDaemonBus__receive_buffer", text)  # noqa: B010

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


def check_interface(interface: str, where: str) -> None:
    """ConfigError naming ``where`` (an option or a file's key) unless python-can knows ``interface``."""
    if interface not in can.interfaces.VALID_INTERFACES:
        known = ", ".join(sorted(can.interfaces.VALID_INTERFACES))
        raise ConfigError(f"{where} {interface!r}: not a python-can interface; known: {known}")


def open_bus(
    interface: str, channel: str | int | None, *, bitrate: int | None = None, **options: Any
) -> can.BusABC:
    """A python-can bus on ``interface``/``channel`` (e.g. socketcan/vcan0, socketcand/can0)."""
    check_interface(interface, "interface")
    kwargs = dict(options)
    if interface == "socketcand":
        if not any(isinstance(f, _Fragments) for f in _SOCKETCAND_LOG.filters):
            _SOCKETCAND_LOG.addFilter(_Fragments())
        kwargs.setdefault("tcp_tune", True)  # TCP_NODELAY/QUICKACK: no 40 ms Nagle/delayed-ACK stalls
    if bitrate is not None:
        kwargs["bitrate"] = bitrate
    if interface == "socketcand" and socketcand_client.connect_to_server is not _connect:
        socketcand_client.connect_to_server = _connect  # bounded where this thread set a deadline
    try:
        if interface == "socketcand":
            host, port = str(kwargs.pop("host", "")), int(kwargs.pop("port", SOCKETCAND_PORT))
            return _Socketcand(str(channel), host, port, timeout=HANDSHAKE, **kwargs)
        return can.Bus(interface=interface, channel=channel, ignore_config=True, **kwargs)
    except (can.CanError, OSError, ValueError, ImportError, NotImplementedError) as exc:
        raise CommunicationError(
            f"cannot open CAN bus interface={interface!r} channel={channel!r}: {exc}"
        ) from exc


def scan_command(
    interface: str, channel: str, bitrate: int | None = None, host: str = "", port: int = 0
) -> str:
    """The ``rig scan`` line for the bus ``open_bus`` would open with these arguments (what to run
    when a node id is wrong)."""
    words = ["rig scan", f"--interface {interface}"]
    if channel:
        words.append(f"--channel {channel}")
    if bitrate:
        words.append(f"--bitrate {bitrate}")
    if interface == "socketcand":
        words.append(f"--host {host} --port {port}")
    return " ".join(words)
