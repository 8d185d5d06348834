"""The cyclic data of a CiA 402 axis, from the mapping in force: where each value is, and the RPDO frame.

``ProcessData`` is built once the mapping is known (written by the host or the device's own):
each value the host reads (statusword, position, velocity, ...) is found in the TPDO that
carries it, decoded with that TPDO's own struct, or, where no TPDO carries it, read by SDO
each time (slow; the set-up warns). The RPDO that carries the target is packed whole: the
host's controlword and target, and every other object the device maps there with the value
it held at set-up (so a fixed mapping's extra objects keep their value).
"""

from __future__ import annotations

import logging
import operator
import struct
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from drivers.cia402_pdo import Key, Pdo, codec
from drivers.tpdo_slot import TpdoSlot

__all__ = ["ProcessData"]

log = logging.getLogger(__name__)


class ProcessData:
    """The values of the mapping in force, and the RPDO's frame (see the module docstring).

    Parameters
    ----------
    od : canopen.ObjectDictionary
        The dictionary in use (each PDO's types).
    tpdos : sequence of Pdo
        The TPDOs in force.
    rpdo : Pdo or None
        The RPDO that carries the target (None: none).
    receive : callable
        ``receive(cob_id, codec)``: the axis's slot for a TPDO.
    read : callable
        ``read(index, subindex)``: the axis's SDO upload, for a value no TPDO carries.
    held : Mapping[Key, int]
        The values the RPDO's other objects held at set-up.
    """

    def __init__(
        self,
        od: Any,
        tpdos: Sequence[Pdo],
        rpdo: Pdo | None,
        *,
        receive: Callable[[int, struct.Struct], TpdoSlot],
        read: Callable[[int, int], Any],
        held: Mapping[Key, int],
    ) -> None:
        self._read = read
        self.tpdos = list(tpdos)  #: the TPDOs in force, in the order of ``slots``
        self.slots: list[TpdoSlot] = []
        self._where: dict[Key, tuple[TpdoSlot, int]] = {}
        for pdo in tpdos:
            slot = receive(pdo.cob_id, codec(od, pdo))
            slot.ttype = pdo.ttype
            self.slots.append(slot)
            for pos, e in enumerate(pdo.entries):
                if e.mine:  # another axis's object in it (a drive of several axes): not this axis's
                    self._where.setdefault(e.key, (slot, pos))
        self.rpdo = rpdo
        self._codec = codec(od, rpdo) if rpdo is not None else None
        self._template = [held.get(e.key, 0) for e in rpdo.entries] if rpdo is not None else []
        self._slots_of_rpdo = {e.key: i for i, e in enumerate(rpdo.entries)} if rpdo is not None else {}

    def mapped(self, key: Key) -> bool:
        """Whether a TPDO carries ``key``.

        Parameters
        ----------
        key : Key
            (index, subindex).

        Returns
        -------
        bool
            A TPDO in force carries it.
        """
        return key in self._where

    def slot_of(self, key: Key) -> TpdoSlot | None:
        """The slot of the TPDO that carries ``key``.

        Parameters
        ----------
        key : Key
            (index, subindex).

        Returns
        -------
        drivers.tpdo_slot.TpdoSlot or None
            Its slot; None where no TPDO carries it.
        """
        hit = self._where.get(key)
        return hit[0] if hit else None

    def value(self, key: Key) -> Any:
        """The value of ``key`` in the last TPDO that carries it, or read now by SDO.

        Parameters
        ----------
        key : Key
            (index, subindex).

        Returns
        -------
        Any
            Its raw value.
        """
        hit = self._where.get(key)
        if hit is None:
            return self._read(*key)
        slot, pos = hit
        return slot.values()[pos]

    def where(self, key: Key) -> tuple[TpdoSlot, int] | None:
        """Where ``key`` is in the TPDOs.

        Parameters
        ----------
        key : Key
            (index, subindex).

        Returns
        -------
        tuple of (drivers.tpdo_slot.TpdoSlot, int) or None
            The slot of the TPDO that carries it and its place among the slot's values.
        """
        return self._where.get(key)

    def reader(self, keys: Sequence[Key]) -> Callable[[], tuple[Any, ...]]:
        """A function giving the values of ``keys`` as ``value`` gives each: straight from the
        TPDOs' values where TPDOs carry them all (picked in one call where one TPDO does).

        Parameters
        ----------
        keys : sequence of Key
            What to read.

        Returns
        -------
        callable
            ``reader()``: their values, in the order of ``keys``.
        """
        hits = [self._where.get(k) for k in keys]
        if None in hits:
            return lambda: tuple([self.value(k) for k in keys])
        places: list[tuple[TpdoSlot, int]] = hits  # type: ignore[assignment]
        if len(keys) > 1 and len({id(slot) for slot, _ in places}) == 1:
            slot = places[0][0]
            pick = operator.itemgetter(*[place for _, place in places])
            return lambda: pick(slot.values())
        return lambda: tuple([slot.values()[place] for slot, place in places])

    def packer(self, keys: Sequence[Key]) -> Callable[..., bytes]:
        """A function of the values of ``keys`` (in that order) giving the RPDO's data as ``frame``
        does: the struct's own ``pack`` where the RPDO carries exactly those, in that order.

        Parameters
        ----------
        keys : sequence of Key
            What the function takes, in order.

        Returns
        -------
        callable
            ``packer(*values)``: the RPDO's data.

        Raises
        ------
        RuntimeError
            No RPDO carries the command.
        """
        if self._codec is None:
            raise RuntimeError("no RPDO carries the command")
        places = [self._slots_of_rpdo.get(k) for k in keys]
        template, pack = self._template, self._codec.pack
        if places == list(range(len(template))):
            return pack

        def packed(*values: int) -> bytes:
            data = list(template)
            for place, value in zip(places, values):
                if place is not None:
                    data[place] = value
            return pack(*data)

        return packed

    def frame(self, values: Mapping[Key, int]) -> bytes:
        """The RPDO's data with ``values`` in their places and the held values elsewhere.

        Parameters
        ----------
        values : Mapping[Key, int]
            Raw values by object.

        Returns
        -------
        bytes
            The RPDO's data.

        Raises
        ------
        RuntimeError
            No RPDO carries the command.
        """
        if self._codec is None:
            raise RuntimeError("no RPDO carries the command")
        data = list(self._template)
        where = self._slots_of_rpdo
        for key, value in values.items():
            if key in where:
                data[where[key]] = value
        return self._codec.pack(*data)

    def carries(self, key: Key) -> bool:
        """Whether the RPDO carries ``key``.

        Parameters
        ----------
        key : Key
            (index, subindex).

        Returns
        -------
        bool
            It does.
        """
        return key in self._slots_of_rpdo
