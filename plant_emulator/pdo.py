"""PDOs of an emulated node (CiA 301): their configuration in the object dictionary, and the data.

``read_pdo`` reads one PDO's communication (0x1400/0x1800 + n) and mapping
(0x1600/0x1A00 + n) parameters; ``check_mapping_write`` enforces the mapping
protocol on an SDO write (CANopenNode ``301/CO_PDO.c`` behaves the same):
a mapping is written only while the PDO is invalid (COB-ID bit 31) and its
sub 0 is 0, each mapped object must exist, be mappable and have the mapped
length, and at most 8 objects of 64 bits in all are enabled. ``pack`` joins
the stored bytes of a TPDO's objects; ``read_pdos`` reads every PDO of a node.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
from drivers.maps.cia import (
    PDO_BLOCK,
    PDO_INVALID,
    PDO_MAX_BITS,
    PDO_MAX_MAPPED,
    PDO_SYNC_MAX,
    SdoAbortCode,
    split_map_entry,
)
from plant_emulator.od_store import ObjectStore

__all__ = [
    "MAPPINGS",
    "PARAMETERS",
    "PdoConfig",
    "PdoTables",
    "check_mapping_write",
    "mappable",
    "pack",
    "read_pdo",
    "read_pdos",
]

log = logging.getLogger(__name__)

#: object indices of the PDO parameters, and of the mapping parameters among them
PARAMETERS = range(cia.RPDO_COMM, cia.TPDO_MAP + PDO_BLOCK)
MAPPINGS = (range(cia.RPDO_MAP, cia.RPDO_MAP + PDO_BLOCK), range(cia.TPDO_MAP, cia.TPDO_MAP + PDO_BLOCK))


@dataclass(frozen=True)
class PdoConfig:
    """One PDO as configured in the object dictionary."""

    number: int  #: 0-based
    cob_id: int  #: its COB-ID
    valid: bool  #: bit 31 of the COB-ID clear
    ttype: int  #: transmission type
    event_timer_ms: int  #: [ms] sub 5 (0: none)
    mapping: tuple[tuple[int, int, int], ...]  #: (index, subindex, bits)
    slices: tuple[tuple[int, int, int, int], ...] = field(init=False)  #: (index, subindex, start, end)
    size: int = field(init=False)  #: mapped data [bytes]

    def __post_init__(self) -> None:
        slices, start = [], 0
        for index, sub, bits in self.mapping:
            slices.append((index, sub, start, start + bits // 8))
            start += bits // 8
        object.__setattr__(self, "slices", tuple(slices))
        object.__setattr__(self, "size", start)


def read_pdo(od: ObjectStore, comm: int, mapping: int, number: int) -> PdoConfig:
    """PDO ``number`` (0-based) from its communication and mapping parameters.

    Parameters
    ----------
    od : ObjectStore
        The node's object store.
    comm : int
        The first communication record (0x1400 or 0x1800).
    mapping : int
        The first mapping record (0x1600 or 0x1A00).
    number : int
        The PDO, 0-based.

    Returns
    -------
    PdoConfig
        The PDO.
    """
    cob = od.read(comm, cia.PDO_COMM_COB_ID)
    count = od.read(mapping, 0)
    timer = od.read(comm, cia.PDO_COMM_EVENT_TIMER) if od.has(comm, cia.PDO_COMM_EVENT_TIMER) else 0
    return PdoConfig(
        number,
        cob & cia.COB_ID_MASK,
        not (cob & PDO_INVALID),
        od.read(comm, cia.PDO_COMM_TYPE),
        timer,
        tuple(split_map_entry(od.read(mapping, s)) for s in range(1, count + 1)),
    )


def check_mapping_write(od: ObjectStore, index: int, subindex: int, data: bytes) -> None:
    """An SDO write of ``data`` to PDO parameter (index, subindex): SdoAbortedError if the
    mapping protocol forbids it (see the module docstring).

    Parameters
    ----------
    od : ObjectStore
        The node's object store.
    index, subindex : int
        The PDO parameter written.
    data : bytes
        The bytes written.

    Raises
    ------
    SdoAbortedError
        If the mapping protocol forbids the write.
    """
    if not any(index in r for r in MAPPINGS):
        return
    if not od.read(index - PDO_BLOCK, cia.PDO_COMM_COB_ID) & PDO_INVALID:
        raise SdoAbortedError(SdoAbortCode.DEVICE_STATE)
    if subindex == 0:
        count = data[0]
        if count > PDO_MAX_MAPPED:
            raise SdoAbortedError(SdoAbortCode.VALUE_TOO_HIGH)
        bits = sum(split_map_entry(od.read(index, s))[2] for s in range(1, count + 1))
        if bits > PDO_MAX_BITS:
            raise SdoAbortedError(SdoAbortCode.PDO_LENGTH_EXCEEDED)
        return
    if od.read(index, 0) != 0:
        raise SdoAbortedError(SdoAbortCode.DEVICE_STATE)
    entry = int.from_bytes(data, "little")
    if entry == 0:
        return
    obj_index, obj_sub, bits = split_map_entry(entry)
    try:
        obj = od.obj(obj_index, obj_sub)
    except SdoAbortedError:
        raise SdoAbortedError(SdoAbortCode.NOT_MAPPABLE) from None
    if not obj.pdo_mappable or len(obj) != bits:
        raise SdoAbortedError(SdoAbortCode.NOT_MAPPABLE)


def mappable(od: ObjectStore, pdo: PdoConfig) -> bool:
    """Every mapped object exists and has the mapped size (an EDS's default mapping may not).

    Parameters
    ----------
    od : ObjectStore
        The node's object store.
    pdo : PdoConfig
        The PDO.

    Returns
    -------
    bool
        Every mapped object exists with the mapped size.
    """
    for index, sub, bits in pdo.mapping:
        try:
            size = len(od.obj(index, sub))
        except SdoAbortedError:
            size = -1
        if size != bits:
            log.warning(
                "PDO%d maps 0x%04X:%d as %d bits, it has %d: unused", pdo.number + 1, index, sub, bits, size
            )
            return False
    return True


def pack(od: ObjectStore, pdo: PdoConfig) -> bytes:
    """The data of TPDO ``pdo``: its objects' stored bytes.

    Parameters
    ----------
    od : ObjectStore
        The node's object store.
    pdo : PdoConfig
        The TPDO.

    Returns
    -------
    bytes
        Its data.
    """
    data = od.data
    try:
        return b"".join([data[i][s][: b - a] for i, s, a, b in pdo.slices])
    except KeyError:  # an object never written: its default
        raw = od.raw
        return b"".join([raw(i, s)[: b - a] for i, s, a, b in pdo.slices])


class PdoTables(NamedTuple):
    """A node's PDOs as its object dictionary configures them now (``read_pdos``)."""

    tpdos: list[PdoConfig]  #: every TPDO the dictionary has
    rpdos: list[PdoConfig]  #: every RPDO the dictionary has
    sync_tpdos: list[PdoConfig]  #: valid, mapped, types 1-240
    event_tpdos: list[PdoConfig]  #: valid, mapped, types 254/255
    rpdo_of_cob: dict[int, PdoConfig]  #: valid, mapped and mappable RPDOs by COB-ID (the first of each)


def read_pdos(store: ObjectStore, od: Any) -> PdoTables:
    """Every PDO whose communication and mapping parameters ``od`` has (``read_pdo``), sorted for
    the node's use.

    Parameters
    ----------
    store : ObjectStore
        The node's object store.
    od : Any
        Its canopen object dictionary.

    Returns
    -------
    PdoTables
        The PDOs.
    """
    tpdos = [
        read_pdo(store, cia.TPDO_COMM + n, cia.TPDO_MAP + n, n)
        for n in range(PDO_BLOCK)
        if cia.TPDO_COMM + n in od and cia.TPDO_MAP + n in od
    ]
    rpdos = [
        read_pdo(store, cia.RPDO_COMM + n, cia.RPDO_MAP + n, n)
        for n in range(PDO_BLOCK)
        if cia.RPDO_COMM + n in od and cia.RPDO_MAP + n in od
    ]
    mapped = [p for p in tpdos if p.valid and p.mapping]
    rpdo_of_cob: dict[int, PdoConfig] = {}
    for pdo in rpdos:
        if pdo.valid and pdo.mapping and mappable(store, pdo):
            rpdo_of_cob.setdefault(pdo.cob_id, pdo)
    return PdoTables(
        tpdos,
        rpdos,
        [p for p in mapped if 1 <= p.ttype <= PDO_SYNC_MAX],
        [p for p in mapped if p.ttype > PDO_SYNC_MAX],
        rpdo_of_cob,
    )
