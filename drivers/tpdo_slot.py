"""How a CANopen axis receives its process data: ``TpdoSlot``, a plain subscriber that keeps one
TPDO's last frame and its timestamp and decodes it with a struct built from the mapping in force.

canopen's ``PdoMap.on_message`` takes a lock and notifies waiters on every frame, which the cycle
does not need. ``pdo_codec`` builds a slot's struct from a canopen PDO map; ``sample_interval``
gives the time between two samples for a speed by difference.
"""

from __future__ import annotations

import struct
from typing import Any

from drivers.errors import CommunicationError
from drivers.producer_watch import ProducerWatch

__all__ = ["TpdoSlot", "pdo_codec", "sample_interval"]


class TpdoSlot:
    """The last frame of one TPDO and its decoder (little-endian, per the mapping in force).

    Parameters
    ----------
    node_id : int
        The node that produces the TPDO.
    cob_id : int
        The TPDO's COB-ID.
    codec : struct.Struct
        Its mapping's decoder (little-endian).
    """

    __slots__ = (
        "_decoded",
        "_decoded_of",
        "cob_id",
        "codec",
        "data",
        "frames",
        "node_id",
        "producers",
        "since",
        "timestamp",
        "ttype",
    )

    def __init__(self, node_id: int, cob_id: int, codec: struct.Struct) -> None:
        self.node_id = node_id
        self.cob_id = cob_id
        self.codec = codec
        self.data: bytes | bytearray = bytes(codec.size)  #: zeros until the first frame (stamp None)
        self.timestamp: float | None = None
        #: its transmission type (CiA 301, 0x1800 sub 2): 1 answers every SYNC, 2-240 every n-th,
        #: 0 acyclic, 254/255 event-driven; set where the mapping in force is known
        self.ttype = 1
        #: the values of the frame ``_decoded_of`` (a frame's data are not changed once received)
        self._decoded: tuple[Any, ...] = ()
        self._decoded_of: bytes | bytearray | None = None
        #: the bus's watch for another producer on this COB-ID (``ProducerWatch.watch``: it counts
        #: ``frames`` against the SYNCs since the count ``since``), or None
        self.producers: ProducerWatch | None = None
        self.frames = 0
        self.since = 0

    def on_frame(self, can_id: int, data: bytes | bytearray, timestamp: float) -> None:
        """Keep a received frame (the network's subscriber callback, on its receive thread).

        Parameters
        ----------
        can_id : int
            The frame's CAN identifier (the slot's COB-ID).
        data : bytes or bytearray
            Its data bytes.
        timestamp : float
            [s] its receive time.
        """
        producers = self.producers
        if producers is not None and not producers.take(self, data):
            return  # not its node's (``ProducerWatch``): not taken
        self.data = data
        self.timestamp = timestamp

    def values(self) -> tuple[Any, ...]:
        """The mapped values of the last frame, decoded once.

        Returns
        -------
        tuple
            The values in the mapping's order (zeros before the first frame).

        Raises
        ------
        CommunicationError
            The frame's length is not its mapping's (named by node and COB-ID).
        """
        data = self.data
        if data is self._decoded_of:
            return self._decoded
        if len(data) != self.codec.size:
            raise CommunicationError(
                f"node {self.node_id}: TPDO 0x{self.cob_id:03X} has {len(data)} bytes, "
                f"its mapping {self.codec.size}"
            )
        self._decoded, self._decoded_of = self.codec.unpack(data), data
        return self._decoded


def sample_interval(last: float | None, stamp: float | None, period: float) -> float:
    """The time from one sample to the next, for a speed by difference.

    Whole periods where the stamps are on the SYNC grid (lock-step), their difference where not
    (real time: a cycle the host skipped, a late SYNC: dividing by one period there made a sample
    after two skipped cycles three times too fast); a period where they cannot tell.

    Parameters
    ----------
    last : float or None
        [s] the stamp of the sample before.
    stamp : float or None
        [s] the stamp of this sample.
    period : float
        [s] the SYNC period.

    Returns
    -------
    float
        [s] the interval.
    """
    if stamp is None or last is None or not stamp > last:
        return period
    dt = stamp - last
    n = round(dt / period)
    return n * period if n >= 1 and abs(dt - n * period) <= 1e-6 * period else dt


def pdo_codec(pdo: Any) -> struct.Struct:
    """A struct for the variables of a canopen PDO map (CANopen is little-endian).

    Parameters
    ----------
    pdo : canopen.pdo.PdoMap
        A saved map of the mapping in force.

    Returns
    -------
    struct.Struct
        Its decoder.

    Raises
    ------
    CommunicationError
        An entry is not numeric.
    """
    formats = []
    for var in pdo.map:
        od_struct = var.od.STRUCT_TYPES.get(var.od.data_type)
        if od_struct is None:
            raise CommunicationError(f"0x{var.index:04X}:{var.subindex:02X} is not a numeric PDO entry")
        formats.append(od_struct.format.lstrip("<"))
    return struct.Struct("<" + "".join(formats))
