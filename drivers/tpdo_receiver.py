"""The TPDOs one CANopen axis receives, a part of ``drivers.canopen_axis.CanopenAxis``.

``TpdoReceiver`` subscribes each TPDO the axis reads to a ``drivers.tpdo_slot.TpdoSlot`` (instead
of canopen's own handler), counted by the bus's producer watch from its making, and says what a
pacing waits for after each SYNC (the TPDOs of transmission type 1) and what it cannot wait for
(CiA 301: 2-240 every n-th SYNC, counted from a start the host does not know; 0, 254, 255 only on
an event). The part owns its slots; what it needs of its axis is ``ReceivingAxis``.
"""

from __future__ import annotations

import struct
from typing import Any, Protocol

import canopen

from drivers.producer_watch import ProducerWatch
from drivers.tpdo_slot import TpdoSlot, pdo_codec

__all__ = ["TpdoReceiver"]


class ReceivingAxis(Protocol):
    """What the receiver needs of its axis (``drivers.canopen_axis.CanopenAxis``)."""

    node_id: int
    network: canopen.Network
    producer_watch: ProducerWatch | None  #: the bus's watch for another producer (set before set-up)


class TpdoReceiver:
    """The slots of the TPDOs an axis receives (see the module docstring).

    Parameters
    ----------
    axis : ReceivingAxis
        The axis that reads them.
    """

    def __init__(self, axis: ReceivingAxis) -> None:
        self.axis = axis
        self.slots: list[TpdoSlot] = []  #: one for each TPDO received, in the order made

    def receive(self, pdo: Any) -> TpdoSlot:
        """Receive TPDO ``pdo`` into a slot, instead of canopen's handler.

        Parameters
        ----------
        pdo : canopen.pdo.PdoMap
            A saved TPDO of the node.

        Returns
        -------
        drivers.tpdo_slot.TpdoSlot
            Its slot, with its transmission type.
        """
        slot = self._slot(pdo.cob_id, pdo_codec(pdo))
        if pdo.trans_type is not None:
            slot.ttype = int(pdo.trans_type)
        network = self.axis.network
        if pdo.on_message in network.subscribers.get(pdo.cob_id, ()):
            network.unsubscribe(pdo.cob_id, pdo.on_message)
        return self._subscribe(slot)

    def receive_cob(self, cob_id: int, codec: struct.Struct) -> TpdoSlot:
        """Receive the TPDO on ``cob_id`` into a slot, counted by the producer watch from now on.

        Parameters
        ----------
        cob_id : int
            Its COB-ID.
        codec : struct.Struct
            Its mapping in force (``drivers.tpdo_slot.pdo_codec``).

        Returns
        -------
        drivers.tpdo_slot.TpdoSlot
            Its slot.
        """
        return self._subscribe(self._slot(cob_id, codec))

    def _slot(self, cob_id: int, codec: struct.Struct) -> TpdoSlot:
        """A slot for the TPDO on ``cob_id``, counted by the producer watch from now on."""
        slot = TpdoSlot(self.axis.node_id, cob_id, codec)
        if self.axis.producer_watch is not None:
            self.axis.producer_watch.watch(slot)
        return slot

    def _subscribe(self, slot: TpdoSlot) -> TpdoSlot:
        self.axis.network.subscribe(slot.cob_id, slot.on_frame)
        self.slots.append(slot)
        return slot

    def has_sample(self) -> bool:
        """Every TPDO received has arrived at least once.

        Returns
        -------
        bool
            No slot is still without a frame.
        """
        return all(slot.timestamp is not None for slot in self.slots)

    def frames(self) -> list[tuple[str, int]]:
        """The TPDOs, as (what it is, its data bytes).

        Returns
        -------
        list of (str, int)
            ``TPDO 0x181`` and its length, for each.
        """
        return [(f"TPDO 0x{s.cob_id:03X}", s.codec.size) for s in self.slots]

    def cob_ids(self) -> list[int]:
        """The COB-IDs of the TPDOs that answer every SYNC (transmission type 1).

        Returns
        -------
        list of int
            What a pacing waits for after each SYNC.
        """
        return [s.cob_id for s in self.slots if s.ttype == 1]

    def not_awaited(self) -> list[tuple[int, int]]:
        """(COB-ID, transmission type) of the TPDOs that do not answer every SYNC.

        Returns
        -------
        list of (int, int)
            What a pacing cannot wait for without counting as owed an answer the node will not send.
        """
        return [(s.cob_id, s.ttype) for s in self.slots if s.ttype != 1]

    def release(self) -> None:
        """Unsubscribe every slot from the network."""
        for slot in self.slots:
            self.axis.network.unsubscribe(slot.cob_id, slot.on_frame)
        self.slots.clear()
