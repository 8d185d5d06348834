"""The CiA 301 communication objects of a device as rows of an EDS table
(``drivers.maps.eds_table``): device type, error register, SYNC and EMCY COB-IDs, name,
heartbeat consumer and producer, identity, error behaviour (``cia301_objects``), store and
restore (``store_objects``), and the PDOs' communication and mapping records (``pdo_comm``,
``pdo_map``, ``pdo_objects``).
"""

from __future__ import annotations

from collections.abc import Sequence

from drivers.maps.eds_table import UINT8, UINT16, UINT32, VSTRING, Obj, Var, record, var

__all__ = ["cia301_objects", "pdo_comm", "pdo_map", "pdo_objects", "store_objects"]


def pdo_comm(
    index: int, kind: str, cob_id: int, *, enabled: bool, ttype: int, subs: Sequence[int] = (1, 2, 3, 5)
) -> Obj:
    """A PDO communication record (``kind`` "R" or "T") with sub-indices ``subs`` (1 COB-ID,
    2 transmission type, 3 inhibit time, 5 event timer, 6 SYNC start value); ``cob_id`` is
    added to $NODEID, with bit 31 set when not ``enabled``.

    Parameters
    ----------
    index : int
        The record's index (0x1400 + n, 0x1800 + n).
    kind : str
        "R" or "T".
    cob_id : int
        Added to $NODEID.
    enabled : bool
        Else bit 31 is set.
    ttype : int
        The transmission type.
    subs : Sequence[int], optional
        The sub-indices it has.

    Returns
    -------
    Obj
        The record.
    """
    n = index - (0x1400 if kind == "R" else 0x1800) + 1
    cob = f"$NODEID+0x{cob_id if enabled else 0x80000000 + cob_id:X}"
    known = {
        1: Var("COB-ID", UINT32, "rw", cob),
        2: Var("Transmission type", UINT8, "rw", str(ttype)),
        3: Var("Inhibit time", UINT16, "rw", "0"),
        5: Var("Event timer", UINT16, "rw", "0"),
        6: Var("SYNC start value", UINT8, "rw", "0"),
    }
    return record(index, f"{kind}PDO{n} communication parameter", [(s, known[s]) for s in subs])


def pdo_map(index: int, kind: str, entries: Sequence[int], *, access: str = "rw", slots: int = 8) -> Obj:
    """A PDO mapping record with ``entries`` in the first of ``slots`` sub-indices; ``access`` "ro"
    or "const" makes a fixed mapping.

    Parameters
    ----------
    index : int
        The record's index (0x1600 + n, 0x1A00 + n).
    kind : str
        "R" or "T".
    entries : Sequence[int]
        Mapping entries (``mapped``).
    access : str, optional
        "rw"; "ro" or "const": a fixed mapping.
    slots : int, optional
        Sub-indices for entries.

    Returns
    -------
    Obj
        The record.
    """
    n = index - (0x1600 if kind == "R" else 0x1A00) + 1
    subs = [(0, Var("Number of mapped objects", UINT8, access, str(len(entries))))]
    subs += [
        (
            s + 1,
            Var(f"Mapped object {s + 1}", UINT32, access, f"0x{entries[s] if s < len(entries) else 0:08X}"),
        )
        for s in range(slots)
    ]
    return Obj(index, f"{kind}PDO{n} mapping parameter", tuple(subs))


def cia301_objects(
    *,
    device_type: int,
    name: str,
    vendor: int,
    product: int,
    heartbeat_ms: int,
    consumers: int,
    software: str = "",
    store: bool = False,
) -> list[Obj]:
    """The CiA 301 objects of a device: type, error register, SYNC and EMCY COB-IDs, name
    (and software version), ``consumers`` heartbeat consumer entries, producer heartbeat,
    identity, error behaviour; with ``store``, 0x1010/0x1011 sub 1 (``store_objects``).

    Parameters
    ----------
    device_type : int
        0x1000.
    name : str
        0x1008, the device's name.
    vendor, product : int
        0x1018 sub 1 and 2.
    heartbeat_ms : int
        [ms] 0x1017, the producer heartbeat.
    consumers : int
        Entries of 0x1016, the heartbeat consumer.
    software : str, optional
        0x100A ("": none).
    store : bool, optional
        Add 0x1010/0x1011 (``store_objects``).

    Returns
    -------
    list[Obj]
        The objects.
    """
    objs = [
        var(0x1000, Var("Device type", UINT32, "ro", f"0x{device_type:08X}")),
        var(0x1001, Var("Error register", UINT8, "ro", "0", pdo=True)),
        var(0x1005, Var("COB-ID SYNC", UINT32, "rw", "0x00000080")),
        var(0x1008, Var("Manufacturer device name", VSTRING, "const", name)),
    ]
    if software:
        objs.append(var(0x100A, Var("Manufacturer software version", VSTRING, "const", software)))
    objs += [
        var(0x1014, Var("COB-ID EMCY", UINT32, "ro", "$NODEID+0x80")),
        *_heartbeat_objects(heartbeat_ms, consumers),
        _identity(vendor, product),
        record(0x1029, "Error behavior", [(1, Var("Communication error", UINT8, "rw", "0"))], kind=0x8),
    ]
    return objs + (store_objects() if store else [])


def _heartbeat_objects(heartbeat_ms: int, consumers: int) -> list[Obj]:
    """0x1016, the heartbeat consumer with ``consumers`` entries, and 0x1017, the producer's
    ``heartbeat_ms`` [ms]."""
    return [
        record(
            0x1016,
            "Consumer heartbeat time",
            [(s, Var(f"Consumer heartbeat time {s}", UINT32, "rw", "0")) for s in range(1, consumers + 1)],
            kind=0x8,
        ),
        var(0x1017, Var("Producer heartbeat time", UINT16, "rw", str(heartbeat_ms))),
    ]


def _identity(vendor: int, product: int) -> Obj:
    """0x1018, the identity: ``vendor``, ``product``, revision 1.0, serial number 1."""
    return record(
        0x1018,
        "Identity object",
        [
            (1, Var("Vendor-ID", UINT32, "ro", f"0x{vendor:08X}")),
            (2, Var("Product code", UINT32, "ro", f"0x{product:08X}")),
            (3, Var("Revision number", UINT32, "ro", "0x00010000")),
            (4, Var("Serial number", UINT32, "ro", "0x00000001")),
        ],
    )


def store_objects() -> list[Obj]:
    """0x1010 and 0x1011 with sub 1 (all parameters), as CiA 301 has them: read, 1 says the device
    saves (restores) on command; written with the signature "save" (0x65766173) it stores them,
    with "load" (0x64616F6C) it takes back the defaults at its next reset.

    Returns
    -------
    list[Obj]
        0x1010 and 0x1011.
    """
    return [
        record(
            0x1010,
            "Store parameters",
            [(1, Var("Save all parameters", UINT32, "rw", "0x00000001"))],
            kind=0x8,
        ),
        record(
            0x1011,
            "Restore default parameters",
            [(1, Var("Restore all default parameters", UINT32, "rw", "0x00000001"))],
            kind=0x8,
        ),
    ]


def pdo_objects(
    rpdo: Sequence[Sequence[int]],
    tpdo: Sequence[Sequence[int]],
    *,
    rpdo_types: Sequence[int],
    tpdo_types: Sequence[int],
    rpdo_enabled: Sequence[bool],
    tpdo_enabled: Sequence[bool],
    rpdo_subs: Sequence[int] = (1, 2, 3, 5),
    access: str = "rw",
) -> list[Obj]:
    """The communication and mapping records of the RPDOs and TPDOs (predefined COB-IDs).

    Parameters
    ----------
    rpdo, tpdo : Sequence[Sequence[int]]
        Each PDO's mapping entries.
    rpdo_types, tpdo_types : Sequence[int]
        Each PDO's transmission type.
    rpdo_enabled, tpdo_enabled : Sequence[bool]
        Whether each is valid.
    rpdo_subs : Sequence[int], optional
        The RPDOs' communication sub-indices.
    access : str, optional
        The mappings' access (``pdo_map``).

    Returns
    -------
    list[Obj]
        The records.
    """
    objs = []
    for n, entries in enumerate(rpdo):
        objs.append(
            pdo_comm(
                0x1400 + n,
                "R",
                0x200 + 0x100 * n,
                enabled=rpdo_enabled[n],
                ttype=rpdo_types[n],
                subs=rpdo_subs,
            )
        )
        objs.append(pdo_map(0x1600 + n, "R", entries, access=access))
    for n, entries in enumerate(tpdo):
        objs.append(
            pdo_comm(
                0x1800 + n,
                "T",
                0x180 + 0x100 * n,
                enabled=tpdo_enabled[n],
                ttype=tpdo_types[n],
                subs=(1, 2, 3, 5, 6),
            )
        )
        objs.append(pdo_map(0x1A00 + n, "T", entries, access=access))
    return objs
