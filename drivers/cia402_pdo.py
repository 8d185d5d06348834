"""The process data of a CiA 402 drive as the host sets it up: a mapping that respects the device,
or the device's own.

``plan`` places the objects the host needs into the PDOs the device has (their number from its
EDS, at most 8 entries and 64 bits each, PDO-mappable objects only); ``write_mapping`` writes
it by the CiA 301 protocol (COB-ID invalid, sub 0 = 0, the entries, sub 0 = n, COB-ID valid),
and ``read_mapping`` reads the mapping in force from a device that keeps its own. Frames are
then packed and unpacked by ``codec``, from the mapping actually in force.

On a drive of several axes (``drivers.maps.logical``: the dictionary is one axis's view) the
node's PDOs are shared out among its axes in order, an equal block each (``share``: 4 RPDOs and
2 axes, RPDO1-2 are axis 1's and RPDO3-4 axis 2's; CiA 402 leaves the split to the device, and
this one keeps every axis's frames its own); a mapping entry is written with the object's index
on the wire (0x6841 for axis 2's statusword) and read back as the axis names it, or as another
axis's (``Entry.axis``).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from drivers.errors import ConfigError, SdoAbort
from drivers.maps import cia
from drivers.maps.cia import PDO_INVALID, PDO_MAX_BITS, PDO_MAX_MAPPED, map_entry, split_map_entry
from drivers.maps.logical import axis_object, object_axis

__all__ = [
    "Entry",
    "Pdo",
    "codec",
    "disable",
    "numbers",
    "plan_rpdo",
    "plan_tpdos",
    "read_mapping",
    "share",
    "variable",
    "write_mapping",
]

Key = tuple[int, int]  #: (index, subindex)


@dataclass(frozen=True)
class Entry:
    """One mapped object: (index, subindex) as the axis names it, its size [bits], and ``axis``: 0
    for the axis's own object or the node's, n for axis n's (another axis of the device; its
    index then as axis 1's)."""

    index: int  #: the object's index, as the axis names it
    subindex: int  #: its sub-index
    bits: int  #: its size [bits]
    axis: int = 0  #: 0: the axis's own (or the node's); n: axis n's

    @property
    def key(self) -> Key:
        return self.index, self.subindex

    @property
    def mine(self) -> bool:
        """The object is the axis's own (or the node's), not another axis's."""
        return not self.axis

    def wire(self, axis: int) -> int:
        """The object's index on the wire.

        Parameters
        ----------
        axis : int
            The axis whose entry this is.

        Returns
        -------
        int
            The index the device sees (0x6841 for axis 2's statusword).
        """
        return axis_object(self.index, self.axis or axis)


@dataclass
class Pdo:
    """One PDO: ``number`` 0-based, ``receive`` for an RPDO (host -> device), its mapping."""

    number: int  #: 0-based
    receive: bool  #: an RPDO (host -> device)
    entries: list[Entry] = field(default_factory=list)  #: its mapping, in order
    cob_id: int = 0  #: its COB-ID (0: the default of its number)
    ttype: int = 1  #: its transmission type (CiA 301)
    valid: bool = True  #: its COB-ID's invalid bit is clear

    @property
    def bits(self) -> int:
        return sum(e.bits for e in self.entries)

    @property
    def name(self) -> str:
        return f"{'RPDO' if self.receive else 'TPDO'}{self.number + 1}"

    @property
    def comm(self) -> int:
        return (cia.RPDO_COMM if self.receive else cia.TPDO_COMM) + self.number

    @property
    def mapping(self) -> int:
        return (cia.RPDO_MAP if self.receive else cia.TPDO_MAP) + self.number


def numbers(od: Any, *, receive: bool) -> list[int]:
    """The 0-based numbers of the PDOs the EDS has (communication and mapping objects both).

    Parameters
    ----------
    od : canopen.ObjectDictionary
        The dictionary in use.
    receive : bool
        RPDOs (else TPDOs).

    Returns
    -------
    list of int
        Their numbers.
    """
    comm, mapping = (cia.RPDO_COMM, cia.RPDO_MAP) if receive else (cia.TPDO_COMM, cia.TPDO_MAP)
    return [n for n in range(cia.PDO_BLOCK) if comm + n in od and mapping + n in od]


def share(od: Any, *, receive: bool) -> list[int]:
    """The PDOs of ``numbers`` that are the axis's to map: on a drive of several axes (``od`` one
    axis's view: its ``axis`` of ``axes``) an equal block of them each, in order; all of them on a
    drive of one axis.

    Parameters
    ----------
    od : canopen.ObjectDictionary
        The dictionary in use (one axis's view).
    receive : bool
        RPDOs (else TPDOs).

    Returns
    -------
    list of int
        The axis's PDO numbers.
    """
    pdos = numbers(od, receive=receive)
    axis, axes = getattr(od, "axis", 1), getattr(od, "axes", 1)
    per = len(pdos) // axes
    return pdos[(axis - 1) * per : axis * per]


def _none_left(od: Any, receive: bool) -> str:
    """Why no PDO is free: the device has none, or none is this axis's."""
    kind = "RPDO" if receive else "TPDO"
    axes = getattr(od, "axes", 1)
    if axes > 1:
        return (
            f"none of the device's {len(numbers(od, receive=receive))} {kind}s is axis "
            f"{getattr(od, 'axis', 1)}'s (they are shared by its {axes} axes in equal blocks)"
        )
    return f"the device has no {kind}"


def variable(od: Any, key: Key) -> Any:
    """The OD variable of ``key``.

    Parameters
    ----------
    od : canopen.ObjectDictionary
        The dictionary in use.
    key : Key
        (index, subindex).

    Returns
    -------
    canopen.objectdictionary.ODVariable or None
        It; None where the EDS lacks it.
    """
    index, sub = key
    if index not in od:
        return None
    obj = od[index]
    if hasattr(obj, "subindices"):
        return obj[sub] if sub in obj.subindices else None
    return obj if sub == 0 else None


def mappable(od: Any, key: Key) -> bool:
    var = variable(od, key)
    return var is not None and bool(var.pdo_mappable)


def plan_rpdo(od: Any, keys: Sequence[Key], *, ttype: int) -> Pdo:
    """The host's objects (controlword and target) together in the device's first RPDO: an RPDO
    is sent whole, so they go in one or the plan fails.

    Parameters
    ----------
    od : canopen.ObjectDictionary
        The dictionary in use.
    keys : sequence of Key
        The objects, in order.
    ttype : int
        Its transmission type.

    Returns
    -------
    Pdo
        The RPDO planned.

    Raises
    ------
    ConfigError
        No RPDO is free, or an object is not mappable or does not fit (named).
    """
    free = share(od, receive=True)
    if not free:
        raise ConfigError(_none_left(od, True))
    pdo = Pdo(free[0], True, ttype=ttype)
    for key in keys:
        var = variable(od, key)
        if var is None or not var.pdo_mappable:
            raise ConfigError(f"0x{key[0]:04X}:{key[1]:02X} cannot be mapped into an RPDO (EDS)")
        pdo.entries.append(Entry(key[0], key[1], len(var)))
    if pdo.bits > PDO_MAX_BITS or len(pdo.entries) > PDO_MAX_MAPPED:
        raise ConfigError(f"{pdo.name}: {pdo.bits} bits in {len(pdo.entries)} objects do not fit one PDO")
    return pdo


def plan_tpdos(od: Any, keys: Sequence[Key], *, ttype: int) -> tuple[list[Pdo], list[Key]]:
    """Place ``keys`` (the needed ones first) in the device's TPDOs, first fit in order, 64 bits
    and 8 objects each.

    Parameters
    ----------
    od : canopen.ObjectDictionary
        The dictionary in use.
    keys : sequence of Key
        The objects, the needed ones first.
    ttype : int
        Their transmission type.

    Returns
    -------
    tuple of (list of Pdo, list of Key)
        The PDOs, and the keys left out (not mappable, or no room left).
    """
    free = share(od, receive=False)
    pdos: list[Pdo] = []
    left: list[Key] = []
    for key in keys:
        var = variable(od, key)
        if var is None or not var.pdo_mappable:
            left.append(key)
            continue
        entry = Entry(key[0], key[1], len(var))
        home = next(
            (p for p in pdos if p.bits + entry.bits <= PDO_MAX_BITS and len(p.entries) < PDO_MAX_MAPPED), None
        )
        if home is None and free:
            home = Pdo(free.pop(0), False, ttype=ttype)
            pdos.append(home)
        if home is None:
            left.append(key)
            continue
        home.entries.append(entry)
    return pdos, left


def write_mapping(write: Callable[[int, int, int], None], pdo: Pdo, *, node_id: int, od: Any) -> None:
    """Write ``pdo`` by the CiA 301 protocol: COB-ID with the invalid bit, transmission type,
    sub 0 = 0, the entries, sub 0 = n, the COB-ID valid.

    Parameters
    ----------
    write : callable
        ``write(index, subindex, value)``: an SDO download (SdoAbort when the device refuses).
    pdo : Pdo
        The mapping.
    node_id : int
        The node (the default COB-ID).
    od : canopen.ObjectDictionary
        The dictionary in use.

    Raises
    ------
    ConfigError
        The PDO has no COB-ID the host can give it.
    """
    base = (cia.COB_RPDO if pdo.receive else cia.COB_TPDO)[pdo.number] + node_id if pdo.number < 4 else 0
    cob = pdo.cob_id or base
    if not cob:
        raise ConfigError(f"{pdo.name}: no predefined COB-ID; the device must give one")
    pdo.cob_id = cob
    write(pdo.comm, cia.PDO_COMM_COB_ID, cob | PDO_INVALID)
    if variable(od, (pdo.comm, cia.PDO_COMM_TYPE)) is not None:
        write(pdo.comm, cia.PDO_COMM_TYPE, pdo.ttype)
    write(pdo.mapping, 0, 0)
    axis = getattr(od, "axis", 1)
    for sub, e in enumerate(pdo.entries, start=1):
        write(pdo.mapping, sub, map_entry(e.wire(axis), e.subindex, e.bits))
    write(pdo.mapping, 0, len(pdo.entries))
    write(pdo.comm, cia.PDO_COMM_COB_ID, cob)


def disable(write: Callable[[int, int, int], None], number: int, *, receive: bool, cob_id: int) -> None:
    """Set the invalid bit of a PDO the host does not use.

    Parameters
    ----------
    write : callable
        ``write(index, subindex, value)``: an SDO download.
    number : int
        The PDO's 0-based number.
    receive : bool
        An RPDO (else a TPDO).
    cob_id : int
        Its COB-ID.
    """
    comm = (cia.RPDO_COMM if receive else cia.TPDO_COMM) + number
    write(comm, cia.PDO_COMM_COB_ID, (cob_id & cia.COB_ID_MASK) | PDO_INVALID)


def read_mapping(read: Callable[[int, int], Any], od: Any, *, receive: bool) -> list[Pdo]:
    """The device's PDOs as they are now (valid or not), read by SDO. A PDO the EDS names that
    the device has not (its COB-ID answered "object does not exist", as a device with fewer PDOs
    than the toolkit's generic EDS answers) is no PDO of the device. An entry is named as the
    axis of ``od`` names it (``Entry``).

    Parameters
    ----------
    read : callable
        ``read(index, subindex)``: an SDO upload.
    od : canopen.ObjectDictionary
        The dictionary in use.
    receive : bool
        RPDOs (else TPDOs).

    Returns
    -------
    list of Pdo
        The mapping in force.
    """
    own = getattr(od, "axis", 1)
    out = []
    for n in numbers(od, receive=receive):
        pdo = Pdo(n, receive)
        try:
            cob = int(read(pdo.comm, cia.PDO_COMM_COB_ID))
        except SdoAbort as exc:
            if exc.code != cia.SdoAbortCode.NO_OBJECT:
                raise
            continue
        pdo.cob_id = cob & cia.COB_ID_MASK
        pdo.ttype = int(read(pdo.comm, cia.PDO_COMM_TYPE))
        count = int(read(pdo.mapping, 0))
        for sub in range(1, count + 1):
            index, subindex, bits = split_map_entry(int(read(pdo.mapping, sub)))
            axis, first = object_axis(index)
            pdo.entries.append(Entry(first, subindex, bits, 0 if axis in (0, own) else axis))
        pdo.valid = not cob & PDO_INVALID
        out.append(pdo)
    return out


def codec(od: Any, pdo: Pdo) -> struct.Struct:
    """A struct for ``pdo``'s entries (CANopen is little-endian).

    Parameters
    ----------
    od : canopen.ObjectDictionary
        The dictionary in use.
    pdo : Pdo
        The mapping in force.

    Returns
    -------
    struct.Struct
        Its decoder.

    Raises
    ------
    ConfigError
        An entry is not a number of its mapped size.
    """
    formats = []
    for e in pdo.entries:
        var = variable(od, e.key)
        fmt = var.STRUCT_TYPES.get(var.data_type) if var is not None else None
        if fmt is None or fmt.size * 8 != e.bits:
            raise ConfigError(f"{pdo.name}: 0x{e.index:04X}:{e.subindex:02X} is not a {e.bits}-bit number")
        formats.append(fmt.format.lstrip("<"))
    return struct.Struct("<" + "".join(formats))
