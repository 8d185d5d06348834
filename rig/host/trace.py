"""The CAN trace of a run: python-can's Vector ASCII writer, with a fast path for the common frame.

The trace gets every frame of every cycle, so its per-frame cost is part of the
cycle. ``AscTrace`` is python-can's ``ASCWriter`` (header, footer, the first
frame, and every frame that is not a classic data frame go through it); a
classic data frame with an 11-bit id is written as the same line from its
timestamp, a head made once per (channel, id, direction, length) and its data. A test
keeps the two writers' lines equal, and reads the trace back with python-can's
``ASCReader``.
"""

from __future__ import annotations

from typing import Any

import can
from can.util import channel2int

__all__ = ["AscTrace"]


class AscTrace(can.ASCWriter):
    """``can.ASCWriter`` with a fast path for classic data frames (see the module docstring)."""

    def __init__(self, file: Any, channel: int = 1) -> None:
        super().__init__(file, channel=channel)
        self._heads: dict[tuple[Any, int, bool, int], str] = {}

    def _head(self, msg: can.Message) -> str:
        """The part of the line between the timestamp and the data, made once per kind of frame."""
        key = (msg.channel, msg.arbitration_id, msg.is_rx, msg.dlc)
        head = self._heads.get(key)
        if head is None:
            n = channel2int(msg.channel)
            channel = self.channel if n is None else n + 1
            rx = "Rx" if msg.is_rx else "Tx"
            head = self._heads[key] = f" {channel}  {msg.arbitration_id:<15X} {rx:<4} d {msg.dlc:x} "
        return head

    def on_message_received(self, msg: can.Message) -> None:
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
        stamp = "%9.6f" % (msg.timestamp - self.started)
        self.file.write(stamp + self._head(msg) + msg.data.hex(" ").upper() + "\n")
