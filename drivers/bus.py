"""Opening a CAN bus from configuration.

``open_bus`` wraps ``can.Bus`` with ``ignore_config=True``, so nothing is read
from ``~/.canrc`` or ``CAN_*`` environment variables by surprise, and turns a
failure into ``CommunicationError`` naming the interface and channel.
"""

from __future__ import annotations

from typing import Any

import can

from drivers.errors import CommunicationError

__all__ = ["open_bus"]


def open_bus(
    interface: str, channel: str | int | None, *, bitrate: int | None = None, **options: Any
) -> can.BusABC:
    """A python-can bus on ``interface``/``channel`` (e.g. socketcan/vcan0, socketcand/can0)."""
    kwargs = dict(options)
    if interface == "socketcand":
        kwargs.setdefault("tcp_tune", True)  # TCP_NODELAY/QUICKACK: no 40 ms Nagle/delayed-ACK stalls
    if bitrate is not None:
        kwargs["bitrate"] = bitrate
    try:
        return can.Bus(interface=interface, channel=channel, ignore_config=True, **kwargs)
    except (can.CanError, OSError, ValueError, ImportError, NotImplementedError) as exc:
        raise CommunicationError(
            f"cannot open CAN bus interface={interface!r} channel={channel!r}: {exc}"
        ) from exc
