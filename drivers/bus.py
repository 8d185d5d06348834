"""Opening a CAN bus from configuration.

``open_bus`` wraps ``can.Bus`` with ``ignore_config=True``, so nothing is read
from ``~/.canrc`` or ``CAN_*`` environment variables by surprise, and turns a
failure into ``CommunicationError`` naming the interface and channel.
``ReceiveWatch`` keeps python-can's receive thread from dying with a traceback when the
bus goes away (a socketcand link reset, an interface down): the error is logged once and
kept in the notifier's ``exception``, where the axes' supervision finds it.
python-can's socketcand client warns "Got incomplete message" whenever a TCP segment ends
inside a frame, which is ordinary TCP; that line is demoted to debug (``_Fragments``). A
socketcand server is reached once first (``_reach``): where nothing listens, or a server
accepts but never greets, one line names host:port within 3 s instead of python-can's 10 s of
retries or a wait for ever. An interface python-can does not know is a ``ConfigError`` naming
the known ones (``check_interface``).
"""

from __future__ import annotations

import logging
import socket
import time
from typing import Any

import can

from drivers.errors import CommunicationError, ConfigError

__all__ = ["ReceiveWatch", "brief", "check_interface", "open_bus"]

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


def _reach(host: str, port: int, timeout: float = 3.0) -> None:
    """One TCP connect to a socketcand server before python-can's own, which retries for 10 s
    logging a warning per try (hundreds of thousands of lines) and then waits for the greeting
    ``< hi >`` for ever: CommunicationError naming host:port when nothing answers, or no
    greeting comes, within ``timeout`` [s]."""
    try:
        link = socket.create_connection((host, port), timeout=timeout)
    except OSError as exc:
        raise CommunicationError(f"cannot reach a socketcand server at {host}:{port}: {exc}") from None
    greeting, deadline = b"", time.monotonic() + timeout
    with link:
        try:
            while len(greeting) < len(b"< hi >"):
                link.settimeout(max(deadline - time.monotonic(), 1e-3))
                chunk = link.recv(256)
                if not chunk:
                    break
                greeting += chunk
        except TimeoutError:
            raise CommunicationError(
                f"the socketcand server at {host}:{port} sent no greeting '< hi >' within {timeout:g} s"
            ) from None
        except OSError as exc:
            raise CommunicationError(f"the socketcand server at {host}:{port}: {exc}") from None
    if not greeting.startswith(b"< hi >"):
        raise CommunicationError(
            f"{host}:{port} is not a socketcand server: it sent {greeting[:40]!r}, not '< hi >'"
        )


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
        _reach(str(kwargs.get("host", "")), int(kwargs.get("port", SOCKETCAND_PORT)))
        kwargs.setdefault("tcp_tune", True)  # TCP_NODELAY/QUICKACK: no 40 ms Nagle/delayed-ACK stalls
    if bitrate is not None:
        kwargs["bitrate"] = bitrate
    try:
        return can.Bus(interface=interface, channel=channel, ignore_config=True, **kwargs)
    except (can.CanError, OSError, ValueError, ImportError, NotImplementedError) as exc:
        raise CommunicationError(
            f"cannot open CAN bus interface={interface!r} channel={channel!r}: {exc}"
        ) from exc
