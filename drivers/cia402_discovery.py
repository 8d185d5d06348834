"""How the host finds out what a CiA 402 drive is, before it writes anything: its type and axis, its
identity, its modes, its units.

``Cia402Discovery`` is a part of ``drivers.cia402.Cia402Axis``, called from its set-up: ``discover``
reads 0x1000 (a CiA 402 drive; on a drive of several axes, the axis's own device type 0x67FF +
0x800 (n - 1): ``drivers.maps.logical``), 0x1018 against the EDS in use, 0x6502 against the mode,
and the units of ``drivers.cia402_units``, each by its standard's type whatever the EDS names
(``drivers.identity.read_standard``). A drive that is not what the configuration says is refused
in one line, and marked so that closing writes nothing to it. ``guard_manufacturer`` keeps the
toolkit's manufacturer objects and modes to its own drive. The part owns what it finds; what it
needs of its axis is ``DiscoveredAxis``.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from typing import Any, Protocol

from drivers.cia402_pdo import variable
from drivers.cia402_units import DriveUnits, discover_units
from drivers.errors import CommunicationTimeout, ConfigError, NodeSilent, SdoAbort
from drivers.identity import (
    STANDARD,
    STANDARD_WRITES,
    TOOLKIT_DRIVE,
    Identity,
    encode_standard,
    read_standard,
)
from drivers.maps import cia
from drivers.maps.cia import CIA_MODE_BITS, MODE_BITS, SUPPORTED_MODE_BITS, Mode
from drivers.maps.cia402_needs import OF_MODE, missing
from drivers.maps.logical import DEVICE_TYPE_OF_AXIS, MULTIPLE_DEVICES, axis_object
from drivers.maps.mode_names import MODE_NAMES, mode_text

__all__ = ["Cia402Discovery"]


class DiscoveredAxis(Protocol):
    """What discovery needs of its axis (``drivers.cia402.Cia402Axis``): its node and names, and
    its SDO access."""

    node: Any
    node_id: int
    name: str
    mode: str | None
    op_mode: Mode
    axis_number: int
    eds_given: bool  #: the EDS in use is the device's own (else the toolkit's generic one)
    eds_hint: str  #: how the user gives the device's own EDS
    device_id: Identity  #: 0x1018 as read (``check_identity``)

    @property
    def where(self) -> str:
        """``node 5`` (and the axis on a drive of several), for messages."""

    def sdo_read(self, index: int, subindex: int = 0) -> Any:
        """An object's value, read by SDO."""

    def sdo_upload(self, index: int, subindex: int = 0) -> bytes:
        """An object's raw bytes as the device answers."""

    def check_identity(self, *, give: str) -> Identity:
        """0x1018 read and checked against the EDS in use (kept as ``device_id``)."""

    def _sdo(self, what: str, index: int, subindex: int) -> contextlib.AbstractContextManager[None]:
        """canopen's SDO errors as the toolkit's, naming node and object."""


class Cia402Discovery:
    """What a CiA 402 drive is, found before anything is written (see the module docstring).

    Parameters
    ----------
    axis : DiscoveredAxis
        The axis it discovers.
    units : Mapping[str, float] | None
        Factors the device may lack (``[axis.units]``: ``drivers.cia402_units``).
    """

    def __init__(self, axis: DiscoveredAxis, units: Mapping[str, float] | None = None) -> None:
        self.axis = axis
        self.given_units = dict(units or {})  #: factors the device may lack, given by the user
        self.units_hint = "[axis.units] {key}"  #: how the user gives a unit the drive lacks
        #: the drive has a position actual value 0x6064 (``discover``; a velocity-only drive has none)
        self.has_position = True
        #: the modes 0x6502 lists (``discover``; None: the drive has no 0x6502)
        self.supported_modes: frozenset[int] | None = None
        #: 0x1000 named another profile (``discover``): the axis must not write CiA 402 objects
        self.not_a_drive = False

    def optional(self, index: int, subindex: int = 0) -> Any:
        """An object the device may lack: its value, or None (absent from the EDS, or refused).
        Without the device's own EDS, a ``STANDARD`` object the generic one lacks is read from
        the device by its standard's type (``read_standard``): what the device has decides.

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        Any
            Its value; None where the device lacks it.
        """
        if variable(self.axis.node.object_dictionary, (index, subindex)) is None:
            if not self.axis.eds_given and (index, subindex) in STANDARD:
                return read_standard(self.axis.sdo_upload, index, subindex)
            return None
        try:
            return self.axis.sdo_read(index, subindex)
        except SdoAbort:
            return None

    def discover(self, *, check_mode: bool = True) -> DriveUnits:
        """Device type, identity (checked against the EDS: ``check_identity``), modes, units and
        whether the drive has a position 0x6064, read by their standard's types, whatever the EDS
        names (``drivers.identity.read_standard``).

        Parameters
        ----------
        check_mode : bool
            Check the mode against 0x6502 and require its factors (not in commissioning).

        Returns
        -------
        drivers.cia402_units.DriveUnits
            The drive's units (the axis keeps them: ``Cia402Axis.discover``).

        Raises
        ------
        NodeSilent
            No SDO answer to 0x1000.
        ConfigError
            Not a CiA 402 drive (or axis), another device than the EDS's, a mode it lacks.
        """
        try:
            device_type = self.axis.sdo_read(cia.DEVICE_TYPE)
        except CommunicationTimeout as exc:
            self.not_a_drive = True  # it never answered: closing sends it no controlword
            raise NodeSilent(
                f"node {self.axis.node_id}: no SDO answer to 0x1000 (device type): no node "
                f"{self.axis.node_id} on this bus, or it is not powered"
            ) from exc
        if device_type & 0xFFFF != cia.PROFILE_DRIVE:
            self.not_a_drive = True  # closing writes no controlword to it (0x6040 is not ours there)
            raise ConfigError(
                f"axis {self.axis.name!r}: node {self.axis.node_id} is not a CiA 402 drive "
                f"(0x1000 = 0x{device_type:08X}: profile {device_type & 0xFFFF})"
            )
        self._check_axis(device_type)
        try:
            self.axis.check_identity(give=self.axis.eds_hint)  # the axis keeps it (its device_id)
        except ConfigError:
            self.not_a_drive = True  # another device than the EDS's: closing writes nothing to it
            raise
        bits = self._standard(cia.SUPPORTED_MODES)
        table = MODE_BITS if self.toolkit_drive else CIA_MODE_BITS  # bits 16-31: the vendor's own
        self.supported_modes = (
            None if bits is None else frozenset(int(m) for m, bit in table.items() if bits & bit)
        )
        if check_mode:
            self._check_mode(bits)
        self.has_position = self._standard(cia.POSITION_ACTUAL) is not None
        return discover_units(
            self._standard,
            self.given_units,
            where=f"{self.axis.name!r} (node {self.axis.node_id})",
            mode=int(self.axis.op_mode) if check_mode else 0,
            hint=self.units_hint,
            has_position=self.has_position,
        )

    def _check_axis(self, device_type: int) -> None:
        """Axis n > 1 of a drive of several (``drivers.maps.logical``): the device must have it, as
        its logical device's type (0x67FF + 0x800 (n - 1), profile 402) says, or, where it keeps
        none, its statusword; else ConfigError before anything is written."""
        n = self.axis.axis_number
        if n == 1:
            return
        own = self._standard(DEVICE_TYPE_OF_AXIS)
        if own is not None and own & 0xFFFF == cia.PROFILE_DRIVE:
            return
        if own is None and self._standard(cia.STATUSWORD) is not None:
            return
        self.not_a_drive = True  # closing writes no controlword to an axis that is not there
        wire = axis_object(DEVICE_TYPE_OF_AXIS, n)
        said = "does not answer" if own is None else f"= 0x{own:08X}: profile {own & 0xFFFF}, not 402"
        raise ConfigError(
            f"axis {self.axis.name!r}: node {self.axis.node_id} has no CiA 402 axis {n}: 0x{wire:04X} "
            f"(axis {n}'s device type) {said}, and 0x1000 = 0x{device_type:08X} "
            f"({'a module of several devices' if device_type >> 16 == MULTIPLE_DEVICES else 'one device'}): "
            "give the axis the drive has (axis = 1 on a drive of one axis)"
        )

    def _standard(self, index: int, subindex: int = 0) -> int | None:
        """A standard object as the device answers (``drivers.identity.read_standard``)."""
        return read_standard(self.axis.sdo_upload, index, subindex)

    def offered(self, bits: int | None) -> str:
        """The modes the drive offers, as 0x6502 says: every mode CiA 402 gives a bit (vl and cstca
        too, which the toolkit does not drive), and bits 16-31 only on the toolkit's own drive.

        Parameters
        ----------
        bits : int or None
            0x6502 as read (None: the drive has none).

        Returns
        -------
        str
            The modes, named.
        """
        if bits is None:
            return "no 0x6502 (the drive does not say which modes it has)"
        codes = [m for m, bit in SUPPORTED_MODE_BITS.items() if bits & bit]
        if self.toolkit_drive:
            codes = sorted(int(m) for m, bit in MODE_BITS.items() if bit >> 16 and bits & bit) + codes
        names = ", ".join(mode_text(m) for m in codes) or "no mode CiA 402 names"
        return f"0x6502 = 0x{bits:08X}: {names}"

    def _check_mode(self, bits: int | None) -> None:
        """The configured mode against the drive, before anything is written: a manufacturer mode
        (negative) only on the toolkit's own drive; a mode 0x6502 lists, where it has one."""
        where = f"axis {self.axis.name!r} (node {self.axis.node_id})"
        if int(self.axis.op_mode) < 0 and not self.toolkit_drive:
            raise ConfigError(
                f"{where}: mode {self.axis.mode!r} is a manufacturer mode of drive-rig's own drive "
                f"(vendor 0x{TOOLKIT_DRIVE[0]:X}, product 0x{TOOLKIT_DRIVE[1]:X}); this drive is "
                f"{self.axis.device_id.text()}, whose manufacturer modes mean what its vendor made them "
                f"mean; it offers {self.offered(bits)}: {self.choose()}"
            )
        if self.supported_modes is not None and int(self.axis.op_mode) not in self.supported_modes:
            raise ConfigError(
                f"{where}: mode {self.axis.mode} is not in 0x6502 ({self.offered(bits)}): {self.choose()}"
            )

    def choose(self) -> str:
        """What to do about a mode the drive does not take: the other modes with a cyclic target
        that it offers (all, where it has no 0x6502) and whose objects its dictionary has (an ip
        that 0x6502 lists without 0x60C1 is not one), or rig drive where it offers none.

        Returns
        -------
        str
            What to do, in words.
        """
        offered, od = self.supported_modes, self.axis.node.object_dictionary
        names = [
            name
            for name, m in MODE_NAMES.items()
            if m in cia.TARGET_OF_MODE
            and m >= 0
            and m != self.axis.op_mode
            and (offered is None or m in offered)
            and not missing(od, OF_MODE.get(m, ()))
        ]
        if not names:
            return (
                "it offers no other mode rig run commands (pv, csp, ip, csv, cst): commission it with "
                "rig drive"
            )
        return f"set the axis's mode to another it offers ({', '.join(names)})"

    @property
    def toolkit_drive(self) -> bool:
        """The toolkit's own drive, positively identified (0x1018 vendor and product), whose
        manufacturer objects and modes the host knows."""
        return self.axis.device_id.toolkit

    def standard_write(self, index: int, subindex: int, value: Any) -> bool:
        """Without the device's own EDS, an entry of ``STANDARD_WRITES`` the generic one does not
        name is downloaded by its standard's type, and the device decides (an abort: SdoAbort):
        True once written; False where the dictionary in use writes it (or, lacking it, refuses
        to: ``NotInDictionary``).

        Parameters
        ----------
        index, subindex : int
            The entry.
        value : Any
            What to write.

        Returns
        -------
        bool
            The entry was written here.
        """
        key = (index, subindex)
        if self.axis.eds_given or key not in STANDARD_WRITES:
            return False
        if variable(self.axis.node.object_dictionary, key) is not None:
            return False
        with self.axis._sdo(f"SDO download of {value!r}", index, subindex):
            wire = axis_object(index, self.axis.axis_number)
            self.axis.node.sdo.download(wire, subindex, encode_standard(index, subindex, value))
        return True

    def guard_manufacturer(self, index: int, what: str) -> None:
        """ConfigError before ``what`` would write manufacturer object ``index`` of a drive that is
        not the toolkit's own (its meaning is that vendor's).

        Parameters
        ----------
        index : int
            The object to be written.
        what : str
            What would write it, for the message.

        Raises
        ------
        ConfigError
            ``index`` is a manufacturer object of another drive than the toolkit's.
        """
        if index in cia.MANUFACTURER_AREA and not self.toolkit_drive:
            var = variable(self.axis.node.object_dictionary, (index, 0))
            name = f" ({var.name})" if var is not None else ""
            raise ConfigError(
                f"{self.axis.where}: {what} would write 0x{index:04X}{name}, a manufacturer object of "
                f"{self.axis.device_id.text()}; drive-rig writes no manufacturer object but on its own drive"
            )
