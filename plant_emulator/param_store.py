"""Store and restore of an emulated device's parameters (CiA 301 0x1010, 0x1011).

A device keeps its parameters where a reset finds them: what the NMT resets and the power-on
restore (``EmulatedNode.reset``) is the node's ``power_on`` image. ``ParameterStore`` is that
image's non-volatile memory, for the life of the emulator's process:

- 0x1010 sub n written with the signature "save" (0x65766173, UNSIGNED32; the bytes ``save``)
  copies the parameters of sub n's range, as they are now, into the image: sub 1 all, sub 2 the
  communication area (0x1000-0x1FFF), sub 3 the application area (0x6000-0x9FFF), sub 4 and up
  the manufacturer area (0x2000-0x5FFF). A parameter is an entry the host may write, but for the
  commands of the moment, which no drive keeps over a reset: the controlword 0x6040, the mode
  0x6060, the targets (0x607A, 0x60FF, 0x6071, 0x60B0-0x60B2, 0x60C1, 0x60FE) and a
  manufacturer entry that can be mapped into a PDO (the toolkit drive's voltage and dq set-points).
- 0x1011 sub n written with "load" (0x64616F6C) puts the defaults of that range (the image at
  the first power-on: the EDS's defaults and the device's own) back into the image: they are
  in force after the next reset, as CiA 301 has it, not at once.
- Another value is refused with SDO abort 0x08000020 (data cannot be transferred or stored).
- Read, each sub answers its EDS default (the zoo's: 1, bit 0: the device stores, or restores,
  on command): what was written is not kept.

The image starts with the first power-on and ends with the process: a new ``rig emulate`` is
a drive fresh from the factory.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
from drivers.maps.cia import SdoAbortCode

__all__ = ["ParameterStore"]

STORE, RESTORE = cia.STORE_PARAMETERS, cia.RESTORE_DEFAULTS
#: the areas of each sub-index (CiA 301 0x1010/0x1011: 1 all, 2 communication, 3 application)
_AREAS = {1: range(0x1000, 0xA000), 2: range(0x1000, 0x2000), 3: range(0x6000, 0xA000)}
#: the commands of the moment: never stored
_COMMANDS = frozenset({0x6040, 0x6060, 0x607A, 0x60FF, 0x6071, 0x60B0, 0x60B1, 0x60B2, 0x60C1, 0x60FE})

Image = dict[int, dict[int, bytes]]  #: index -> subindex -> bytes


class ParameterStore:
    """0x1010/0x1011 of ``od`` (canopen's object dictionary) over the node's reset image.

    Parameters
    ----------
    od : Any
        canopen's object dictionary of the node.
    raw : Callable[[int, int], bytes]
        (index, subindex) -> the stored bytes.
    image : Callable[[], Image | None]
        The node's reset image (None: not yet taken).
    """

    def __init__(self, od: Any, raw: Callable[[int, int], bytes], image: Callable[[], Image | None]) -> None:
        self.od = od
        self.raw = raw  #: an entry's bytes as they are now (stored, or its default)
        self.image = image  #: the node's reset image (None before its first power-on)
        self.factory: Image | None = None  #: the image at the first power-on

    def power_on(self, data: Image) -> Image:
        """The reset image of the first power-on (a copy of the node's ``data``), kept as the
        defaults a restore puts back.

        Parameters
        ----------
        data : Image
            The node's reset image.

        Returns
        -------
        Image
            Its copy, kept as the defaults.
        """
        self.factory = {i: dict(subs) for i, subs in data.items()}
        return {i: dict(subs) for i, subs in data.items()}

    def on_write(self, index: int, subindex: int, data: bytes) -> None:
        """An SDO write to 0x1010/0x1011 (before it lands): store into, or restore the defaults of,
        the reset image; a wrong signature is refused (SdoAbortedError 0x08000020).

        Parameters
        ----------
        index, subindex : int
            The object written.
        data : bytes
            The bytes written.

        Raises
        ------
        SdoAbortedError
            If the signature is wrong (0x08000020).
        """
        image = self.image()
        if image is None:
            return
        signature = int.from_bytes(data[:4], "little") if len(data) >= 4 else None
        area = _AREAS.get(subindex, cia.MANUFACTURER_AREA)
        if index == STORE and signature == cia.SAVE_SIGNATURE and subindex:
            self._save(area, image)
        elif index == RESTORE and signature == cia.LOAD_SIGNATURE and subindex:
            self._restore(area, image)
        else:
            raise SdoAbortedError(SdoAbortCode.STORE_FAILED)

    def _parameters(self, area: range) -> list[tuple[int, int]]:
        """The (index, subindex) of ``area``'s parameters (see the module docstring)."""
        keys = []
        for index in self.od:
            if index not in area or index in _COMMANDS or index in (STORE, RESTORE):
                continue
            obj = self.od[index]
            for var in obj.values() if hasattr(obj, "subindices") else (obj,):
                if not var.writable or (index in cia.MANUFACTURER_AREA and var.pdo_mappable):
                    continue
                keys.append((index, var.subindex))
        return keys

    def _save(self, area: range, image: Image) -> None:
        for index, sub in self._parameters(area):
            image.setdefault(index, {})[sub] = bytes(self.raw(index, sub))

    def _restore(self, area: range, image: Image) -> None:
        factory = self.factory or {}
        for index, sub in self._parameters(area):
            if sub in factory.get(index, {}):
                image.setdefault(index, {})[sub] = factory[index][sub]
            else:
                image.get(index, {}).pop(sub, None)  # its EDS default, at the next reset

    @staticmethod
    def handles(index: int) -> bool:
        """0x1010 or 0x1011: a write the store acts on, whose bytes are not kept (a read answers
        the EDS's default, 1: bit 0, the device stores or restores on command).

        Parameters
        ----------
        index : int
            An object's index.

        Returns
        -------
        bool
            It is 0x1010 or 0x1011.
        """
        return index in (STORE, RESTORE)
