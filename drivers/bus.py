"""Opening a CAN bus from configuration.

``open_bus`` wraps ``can.Bus`` with ``ignore_config=True``, so nothing is read
from ``~/.canrc`` or ``CAN_*`` environment variables by surprise, and turns a
failure into ``CommunicationError`` naming the interface and channel. socketcand is opened as
``drivers.socketcand_client.SocketcandBus`` (python-can's client with its connect and handshake
bounded by ``HANDSHAKE``, 3 s together, and a lean frame path). ``ReceiveWatch`` keeps
python-can's receive thread from dying with a traceback when the bus goes away (a socketcand
link reset, an interface down): the error is logged once and kept in the notifier's
``exception``, where the axes' supervision finds it. An interface python-can does not know is a
``ConfigError`` naming the known ones (``check_interface``). A bus that does not open is a
``CommunicationError`` saying the likely cause and the fix (``bus_fix``, ``SOCKETCAND_FIX``):
start ``rig emulate``, set up vcan, give the server's --host and --port.
"""

from __future__ import annotations

import errno
import logging
import time
from typing import Any

import can

from drivers.errors import CommunicationError, ConfigError, brief
from drivers.socketcand_client import SocketcandBus

__all__ = ["SOCKETCAND_FIX", "ReceiveWatch", "bus_fix", "check_interface", "open_bus", "scan_command"]

log = logging.getLogger(__name__)


class ReceiveWatch(can.Listener):
    """A notifier listener that handles receive errors: logged once, then the receive thread
    retries every ``pause`` [s] (not a busy loop) until it is stopped.

    Parameters
    ----------
    pause : float, optional
        [s] between two retries of the receive thread after an error.
    """

    def __init__(self, pause: float = 0.05) -> None:
        self.pause = pause
        self.error: Exception | None = None

    def on_message_received(self, msg: can.Message) -> None:
        """Frames are for the other listeners.

        Parameters
        ----------
        msg : can.Message
            A frame received (ignored).
        """

    def on_error(self, exc: Exception) -> None:
        """Keep the first receive error, log it once, and pause before the thread retries.

        Parameters
        ----------
        exc : Exception
            The error python-can's receive thread met.
        """
        if self.error is None:
            self.error = exc
            log.error("the bus is lost: %s", brief(exc))
        time.sleep(self.pause)


SOCKETCAND_PORT = 29536  #: python-can's and socketcand's default port
HANDSHAKE = 3.0  #: [s] a socketcand connection's connect, greeting, open and rawmode, all together
#: the likely cause of a socketcand server not answering, and the fix
SOCKETCAND_FIX = (
    "is a socketcand server running there? Start one (rig emulate --device NAME, or --preset NAME, serves "
    f"on 127.0.0.1:{SOCKETCAND_PORT}; socketcand -i can0 serves a real bus), or give its --host and --port"
)


def check_interface(interface: str, where: str) -> None:
    """ConfigError naming ``where`` (an option or a file's key) unless python-can knows ``interface``.

    Parameters
    ----------
    interface : str
        The python-can interface name (``socketcan``, ``socketcand``, ``pcan`` ...).
    where : str
        What gave it (an option or a file's key), named in the error.

    Raises
    ------
    ConfigError
        If python-can does not know ``interface`` (the known ones named).
    """
    if interface not in can.interfaces.VALID_INTERFACES:
        known = ", ".join(sorted(can.interfaces.VALID_INTERFACES))
        raise ConfigError(f"{where} {interface!r}: not a python-can interface; known: {known}")


def open_bus(
    interface: str, channel: str | int | None, *, bitrate: int | None = None, **options: Any
) -> can.BusABC:
    """A python-can bus on ``interface``/``channel`` (e.g. socketcan/vcan0, socketcand/can0).

    Parameters
    ----------
    interface : str
        The python-can interface name.
    channel : str | int | None
        The channel on it (``vcan0``, ``can0``; socketcand: the remote bus).
    bitrate : int | None, optional
        [bit/s], where the interface sets it; None leaves it.
    **options : Any
        Further arguments of the interface (socketcand: ``host``, ``port``).

    Returns
    -------
    can.BusABC
        The open bus.

    Raises
    ------
    CommunicationError
        If python-can cannot open it (interface and channel named).
    """
    check_interface(interface, "interface")
    kwargs = dict(options)
    if bitrate is not None:
        kwargs["bitrate"] = bitrate
    if interface == "socketcand":
        host, port = str(kwargs.pop("host", "")), int(kwargs.pop("port", SOCKETCAND_PORT))
        try:
            return SocketcandBus(str(channel), host, port, timeout=HANDSHAKE, **kwargs)
        except CommunicationError as exc:
            raise CommunicationError(f"{exc}: {SOCKETCAND_FIX}") from None
    try:
        return can.Bus(interface=interface, channel=channel, ignore_config=True, **kwargs)
    except (can.CanError, OSError, ValueError, ImportError, NotImplementedError) as exc:
        raise CommunicationError(
            f"cannot open CAN bus interface={interface!r} channel={channel!r}: {str(exc).rstrip('.')}: "
            f"{bus_fix(interface, channel, exc)}"
        ) from exc


def bus_fix(interface: str, channel: object, exc: BaseException) -> str:
    """The likely cause of python-can not opening a bus, and the fix.

    Parameters
    ----------
    interface : str
        python-can's interface.
    channel : object
        Its channel.
    exc : BaseException
        What python-can raised (its ``errno``, or its cause's, names the cause).

    Returns
    -------
    str
        The cause and the fix, in words (the vcan set-up commands, ``rig emulate``, ...).
    """
    code = getattr(exc, "errno", None) or getattr(exc.__cause__, "errno", None)
    if interface == "socketcan":
        if code == errno.EAFNOSUPPORT:
            return (
                "this kernel offers no SocketCAN (not Linux, or the can module is not loaded: sudo modprobe "
                "can): load it, or reach an emulator over --interface socketcand beside rig emulate"
            )
        if code == errno.ENODEV:
            return (
                f"there is no network interface {channel}: set it up (a virtual bus: sudo modprobe vcan; "
                f"sudo ip link add dev {channel} type vcan; sudo ip link set up {channel}; an adapter: "
                f"sudo ip link set {channel} up type can bitrate 500000), or use --interface socketcand "
                "beside rig emulate"
            )
        if code == errno.ENETDOWN:
            return f"the interface {channel} is down: sudo ip link set up {channel}"
    return (
        f"check that the adapter is plugged in and its driver for python-can's {interface!r} interface is "
        "installed (python-can's interface pages), or use --interface socketcand beside rig emulate"
    )


def scan_command(
    interface: str, channel: str, bitrate: int | None = None, host: str = "", port: int = 0
) -> str:
    """The ``rig scan`` line for the bus ``open_bus`` would open with these arguments (what to run
    when a node id is wrong).

    Parameters
    ----------
    interface, channel : str
        The bus's interface and channel.
    bitrate : int | None, optional
        [bit/s], if given.
    host, port, optional
        The socketcand server's address (socketcand only).

    Returns
    -------
    str
        The ``rig scan ...`` command line.
    """
    words = ["rig scan", f"--interface {interface}"]
    if channel:
        words.append(f"--channel {channel}")
    if bitrate:
        words.append(f"--bitrate {bitrate}")
    if interface == "socketcand":
        words.append(f"--host {host} --port {port}")
    return " ".join(words)
