"""How long a CAN frame holds the bus, and a bus that carries no more than its bit rate.

``frame_bits`` is the classic (CAN 2.0) data frame's length with the worst case of bit
stuffing, as CAN schedulability analysis takes it (Davis, Burns, Bril, Lukkien, "Controller
Area Network (CAN) schedulability analysis: Refuted, revisited and revised", Real-Time
Systems 35, 2007, section 3):

    C = g + 8 s + 13 + floor((g + 8 s - 1) / 4)   [bits]

with ``s`` data bytes, ``g`` = 34 for an 11-bit identifier and 54 for a 29-bit one (the bits
from the start of frame to the end of the CRC, which stuffing applies to, less the data), and
13 the CRC delimiter, acknowledgement, end of frame and interframe space, which it does not.
An 8-byte standard frame takes 135 bits (135 us at 1 Mbit/s: 7,407 frames/s at most); real data
stuff fewer bits (111 without any; Nolte et al., RTSS 2001, found real frames about 10 % below
the worst case), so this bus carries at most 18 % fewer frames than a real one.

``BusTime`` is the bus of one bit rate shared by every sender: ``carry`` books a frame at
the end of what is booked (or now, on an idle bus); ``wait`` is how long a sender must hold
its next frame so that no more than ``burst`` [s] of frames are ever booked ahead, as a CAN
controller's transmit queue holds a sender that outruns the bus.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the CLI reads DEFAULT_BITRATE without python-can's import time
    import can

__all__ = ["DEFAULT_BITRATE", "BusTime", "data_frame_bits", "frame_bits"]

DEFAULT_BITRATE = 1_000_000  #: [bit/s] CANopen's fastest classic bit rate (CiA 301 bit timing table)
_STUFFED_HEAD = {False: 34, True: 54}  #: g: SOF .. CRC bits that stuffing applies to, less the data
_UNSTUFFED_TAIL = 13  #: CRC delimiter 1, ACK 2, EOF 7, interframe space 3


def data_frame_bits(size: int, *, extended: bool = False) -> int:
    """Bits a classic data frame of ``size`` data bytes holds the bus for, stuffing at its worst
    (module docstring); ``extended``: a 29-bit identifier.

    Parameters
    ----------
    size : int
        Data bytes, 0-8.
    extended : bool, optional
        A 29-bit identifier (else 11-bit).

    Returns
    -------
    int
        Bits on the bus, worst-case stuffing and the interframe space included.
    """
    g = _STUFFED_HEAD[extended]
    data = 8 * min(size, 8)
    return g + data + _UNSTUFFED_TAIL + (g + data - 1) // 4


def frame_bits(msg: can.Message) -> int:
    """Bits ``msg`` holds the bus for (``data_frame_bits``); a remote frame carries no data bytes.

    Parameters
    ----------
    msg : can.Message
        The frame.

    Returns
    -------
    int
        Bits on the bus (``data_frame_bits``).
    """
    return data_frame_bits(0 if msg.is_remote_frame else msg.dlc, extended=bool(msg.is_extended_id))


class BusTime:
    """A CAN bus of ``bitrate`` [bit/s] that books frames back to back; ``burst`` [s] of them
    may be booked ahead of now. Times are ``time.monotonic()`` seconds.

    Parameters
    ----------
    bitrate : float, optional
        [bit/s], > 0.
    burst : float, optional
        [s] of frames that may be booked ahead of now, >= 0.

    Raises
    ------
    ValueError
        If ``bitrate`` <= 0 or ``burst`` < 0.
    """

    def __init__(self, bitrate: float = DEFAULT_BITRATE, *, burst: float = 0.002) -> None:
        if not bitrate > 0.0:
            raise ValueError(f"bit rate {bitrate} bit/s: must be > 0")
        if not burst >= 0.0:
            raise ValueError(f"burst {burst} s: must be >= 0")
        self.bitrate = float(bitrate)
        self.burst = burst
        self.free_at = 0.0  #: [s] the end of the frames booked so far
        self.frames = 0  #: frames carried
        self.busy = 0.0  #: [s] of bus time they took

    def carry(self, msg: can.Message, now: float) -> None:
        """Book ``msg`` on the bus at ``now`` [s] (after what is booked already).

        Parameters
        ----------
        msg : can.Message
            The frame sent.
        now : float
            [s] ``time.monotonic()`` when it was handed to the bus.
        """
        took = frame_bits(msg) / self.bitrate
        self.free_at = max(self.free_at, now) + took
        self.frames += 1
        self.busy += took

    def wait(self, now: float) -> float:
        """[s] a sender must hold its next frame at ``now`` (0: send it).

        Parameters
        ----------
        now : float
            [s] ``time.monotonic()``.

        Returns
        -------
        float
            [s] to hold the next frame (0: send it now).
        """
        return max(0.0, self.free_at - now - self.burst)
