"""The CAN trace of a run: python-can's Vector ASCII writer, with a fast path for the common frame.

The trace gets every frame of every cycle, so its per-frame cost is part of the
cycle. ``AscTrace`` is python-can's ``ASCWriter`` (header, footer, the first
frame, and every frame that is not a classic data frame go through it); a
classic data frame with an 11-bit id is written as the same line: its timestamp
(formatted once for the frames that share it), a head made once per (channel, id,
direction, length) and its data. A test keeps the two writers' lines equal, and
reads the trace back with python-can's ``ASCReader``.

Two things python-can's writer gets wrong are set right here: the milliseconds of the
header's dates are written with three digits (``.062``, not ``.62``, which readers take
for 620 ms), and ``TracedNetwork`` gives the trace the frames the host sends (a bus
delivers only what the others send): SYNC, RPDOs, SDO requests, NMT, heartbeat, each
marked Tx; the frames received are Rx (``received``: python-can's socketcan marks a frame another
socket of the same machine sent as Tx, as every frame of a vcan or of an emulator on the
host's own can0 is; docs/testing.md). SYNCs the kernel's broadcast manager sends
(``[bus] interface = "socketcan"`` in real time) do not pass through the host and are
not in the trace.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from datetime import datetime
from typing import Any

import can
import canopen
from can.util import channel2int

__all__ = ["AscTrace", "TracedNetwork", "attach_received", "detach_received", "received"]


class AscTrace(can.ASCWriter):
    """``can.ASCWriter`` with a fast path for classic data frames (module docstring).

    Parameters
    ----------
    file : Any
        The trace's file or path (``can.ASCWriter``'s).
    channel : int
        The channel written where a frame has none.
    """

    def __init__(self, file: Any, channel: int = 1) -> None:
        super().__init__(file, channel=channel)
        self._heads: dict[tuple[Any, int, bool, int], str] = {}
        self._stamp: tuple[float, str] = (math.nan, "")  #: the last timestamp [s] and its text

    def _format_header_datetime(self, dt: datetime) -> str:
        """The header's date with its milliseconds in three digits (CANoe's form)."""
        return dt.strftime(f"%a %b %d %H:%M:%S.{dt.microsecond // 1000:03d} %Y")

    def _head(self, key: tuple[Any, int, bool, int]) -> str:
        """The part of a line between its timestamp and its data, made once per kind of frame:
        ``key`` is (channel, id, is_rx, dlc)."""
        n = channel2int(key[0])
        channel = self.channel if n is None else n + 1
        rx = "Rx" if key[2] else "Tx"
        head = self._heads[key] = f" {channel}  {key[1]:<15X} {rx:<4} d {key[3]:x} "
        return head

    def on_message_received(self, msg: can.Message) -> None:
        """Write ``msg``'s line (python-can's writer for any frame but a classic 11-bit data frame).

        Parameters
        ----------
        msg : can.Message
            The frame.
        """
        if (
            not self.header_written
            or msg.is_fd
            or msg.is_error_frame
            or msg.is_remote_frame
            or msg.is_extended_id
            or msg.timestamp is None
            or msg.timestamp < self.started
        ):
            super().on_message_received(msg)
            return
        key = (msg.channel, msg.arbitration_id, msg.is_rx, msg.dlc)
        try:
            head = self._heads[key]
        except KeyError:
            head = self._head(key)
        stamp = self._stamp  # the frames of a lock-step cycle share theirs: formatted once
        if stamp[0] != msg.timestamp:
            stamp = self._stamp = (msg.timestamp, "% 9.6f" % (msg.timestamp - self.started))
        self.file.write(f"{stamp[1]}{head}{msg.data.hex(' ').upper()}\n")


class TracedNetwork(canopen.Network):
    """canopen's ``Network`` whose every frame sent also goes to ``tx_tap`` as a Tx frame.

    Stamped with the wall clock [s] (the clock of the frames received). A frame is sent and traced
    under ``trace_lock``, which the listener of the frames received (`received`) takes too: an
    answer cannot be traced before the request it answers.

    Parameters
    ----------
    *args, **kwargs : Any
        ``canopen.Network``'s.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.tx_tap: Callable[[can.Message], None] | None = None
        self.trace_lock = threading.Lock()

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        """Send a frame (``canopen.Network.send_message``), and trace it.

        Parameters
        ----------
        can_id : int
            Its COB-ID.
        data : bytes
            Its data.
        remote : bool
            A remote frame.
        """
        if self.tx_tap is None:
            super().send_message(can_id, data, remote)
            return
        with self.trace_lock:
            super().send_message(can_id, data, remote)
            tap = self.tx_tap
            if tap is not None:
                tap(
                    can.Message(
                        timestamp=time.time(),
                        arbitration_id=can_id,
                        data=bytes(data),
                        is_extended_id=can_id > 0x7FF,
                        is_remote_frame=remote,
                        is_rx=False,
                    )
                )


def received(
    tap: Callable[[can.Message], None], lock: threading.Lock | None = None
) -> Callable[[can.Message], None]:
    """A bus listener that gives ``tap`` every frame it receives, marked Rx.

    What the host's own socket receives was sent by another node, whatever the kernel says about
    where it came from.

    Parameters
    ----------
    tap : Callable[[can.Message], None]
        Where the frames go.
    lock : threading.Lock | None
        ``TracedNetwork.trace_lock``: taken, so a frame comes after any frame being sent has been
        traced (None: no lock).

    Returns
    -------
    Callable[[can.Message], None]
        The listener.
    """

    def on_received(msg: can.Message) -> None:
        if not msg.is_rx:
            msg.is_rx = True
        if lock is None:
            tap(msg)
            return
        with lock:
            tap(msg)

    return on_received


def attach_received(
    network: TracedNetwork, tap: Callable[[can.Message], None]
) -> Callable[[can.Message], None]:
    """Give ``tap`` every frame ``network`` receives (`received`), ahead of canopen's own listener.

    canopen's wakes the SDO client, which may send its next request before a listener after it has
    traced the answer. The list is replaced, not changed, under the receive thread's loop.

    Parameters
    ----------
    network : TracedNetwork
        The network, connected.
    tap : Callable[[can.Message], None]
        Where the frames go.

    Returns
    -------
    Callable[[can.Message], None]
        The listener, for `detach_received`.
    """
    listener = received(tap, network.trace_lock)
    notifier = network.notifier
    if notifier is not None:
        notifier.listeners = [listener, *notifier.listeners]
    return listener


def detach_received(network: TracedNetwork, listener: Callable[[can.Message], None]) -> None:
    """Take the listener `attach_received` returned off ``network``.

    Parameters
    ----------
    network : TracedNetwork
        The network.
    listener : Callable[[can.Message], None]
        The listener.
    """
    notifier = network.notifier
    if notifier is not None:
        notifier.listeners = [x for x in notifier.listeners if x is not listener]
