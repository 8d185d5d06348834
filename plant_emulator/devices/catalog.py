"""The CiA 402 objects a zoo drive may have, as tables, with defaults in the drive's own units.

Object names are CiA 402's; defaults given in SI (``("pos" | "vel", x)``: x rad, or rad/s and
rad/s^2) are converted with the twin's ``per_rad``. ``catalog(twin)`` gives every object;
``plant_emulator.devices.build`` picks each drive's.
"""

from __future__ import annotations

from typing import Any, Protocol

from drivers.maps.eds_writer import INT8, INT16, INT32, UINT8, UINT16, UINT32, Obj, Var, record, var

__all__ = ["catalog"]


class Units(Protocol):
    """What the tables need of a twin."""

    @property
    def increments(self) -> int: ...
    @property
    def feed(self) -> int: ...
    @property
    def position_unit(self) -> int: ...
    @property
    def velocity_unit(self) -> int: ...
    def per_rad(self, velocity: bool) -> float: ...


#: CiA 402 variables a zoo drive may have: index -> (name, type, access, mappable, default); a
#: default ("pos" | "vel", x) is x rad (or rad/s, rad/s^2) in the drive's own units
_VARIABLES: dict[int, tuple[str, int, str, bool, Any]] = {
    0x6007: ("Abort connection option code", INT16, "rw", False, 1),
    0x6062: ("Position demand value", INT32, "ro", True, 0),
    0x603F: ("Error code", UINT16, "ro", True, 0),
    0x605A: ("Quick stop option code", INT16, "rw", False, 2),
    0x605D: ("Halt option code", INT16, "rw", False, 1),
    0x605E: ("Fault reaction option code", INT16, "rw", False, 2),
    0x6065: ("Following error window", UINT32, "rw", False, ("pos", 2.0)),
    0x6066: ("Following error time out", UINT16, "rw", False, 10),  # ms
    0x6071: ("Target torque", INT16, "rw", True, 0),
    0x6072: ("Max torque", UINT16, "rw", True, 3000),  # per mille
    0x6073: ("Max current", UINT16, "rw", False, 3000),
    0x6075: ("Motor rated current", UINT32, "rw", False, 10000),  # mA
    0x6076: ("Motor rated torque", UINT32, "rw", False, 235),  # mN m
    0x6077: ("Torque actual value", INT16, "ro", True, 0),
    0x6078: ("Current actual value", INT16, "ro", True, 0),
    0x607C: ("Home offset", INT32, "rw", False, 0),
    0x6080: ("Max motor speed", UINT32, "rw", False, 6000),  # rpm
    0x6081: ("Profile velocity", UINT32, "rw", True, ("vel", 100.0)),
    0x6083: ("Profile acceleration", UINT32, "rw", True, ("vel", 1000.0)),
    0x6084: ("Profile deceleration", UINT32, "rw", True, ("vel", 1000.0)),
    0x6085: ("Quick stop deceleration", UINT32, "rw", True, ("vel", 2000.0)),
    0x6098: ("Homing method", INT8, "rw", False, 35),
    0x609A: ("Homing acceleration", UINT32, "rw", False, ("vel", 500.0)),
    0x60C0: ("Interpolation sub mode select", INT16, "rw", False, 0),  # 0: linear
    0x60F4: ("Following error actual value", INT32, "ro", True, 0),
    0x60FD: ("Digital inputs", UINT32, "ro", True, 0),
}
#: CiA 402 records and arrays: index -> (name, kind, [(sub, name, type, mappable, default[, access])]),
#: each entry rw unless it says
_RECORDS: dict[int, tuple[str, int, list[tuple[Any, ...]]]] = {
    0x607D: (
        "Software position limit",
        0x8,
        [
            (1, "Min position limit", INT32, False, -(2**31)),
            (2, "Max position limit", INT32, False, 2**31 - 1),
        ],
    ),
    0x608F: (
        "Position encoder resolution",
        0x9,
        [(1, "Encoder increments", UINT32, False, "increments"), (2, "Motor revolutions", UINT32, False, 1)],
    ),
    0x6091: (
        "Gear ratio",
        0x9,
        [(1, "Motor revolutions", UINT32, False, 1), (2, "Shaft revolutions", UINT32, False, 1)],
    ),
    0x6092: (
        "Feed constant",
        0x9,
        [(1, "Feed", UINT32, False, "feed"), (2, "Shaft revolutions", UINT32, False, 1)],
    ),
    0x6099: (
        "Homing speeds",
        0x8,
        [
            (1, "Speed during search for switch", UINT32, False, ("vel", 20.0)),
            (2, "Speed during search for zero", UINT32, False, ("vel", 2.0)),
        ],
    ),
    0x60C1: ("Interpolation data record", 0x8, [(1, "Interpolation data record 1", INT32, True, 0)]),
    0x60C2: (  # 0.4 ms: the dc-servo preset's period
        "Interpolation time period",
        0x9,
        [
            (1, "Interpolation time period value", UINT8, False, 4),
            (2, "Interpolation time index", INT8, False, -4),
        ],
    ),
    0x60C3: (  # general SYNC (sub 1 = 0), an interpolation cycle every SYNC (sub 2 = 1)
        "Interpolation sync definition",
        0x8,
        [
            (1, "Synchronize on group", UINT8, False, 0, "ro"),
            (2, "ip sync every n event", UINT8, False, 1),
        ],
    ),
    0x60C4: (
        "Interpolation data configuration",
        0x9,
        [
            (1, "Maximum buffer size", UINT32, False, 16, "ro"),
            (2, "Actual buffer size", UINT32, False, 16),
            (3, "Buffer organisation", UINT8, False, 0),  # 0: FIFO
            (4, "Buffer position", UINT16, False, 0),  # rw in CiA 402; a FIFO shows its fill
            (5, "Size of data record", UINT8, False, 4, "wo"),
            (6, "Buffer clear", UINT8, False, 1, "wo"),
        ],
    ),
    0x60FE: (
        "Digital outputs",
        0x8,
        [(1, "Physical outputs", UINT32, True, 0), (2, "Bit mask", UINT32, False, 0)],
    ),
}


def _default(t: Units, value: Any) -> str:
    """A table's default as EDS text, in ``t``'s units."""
    if isinstance(value, tuple):
        kind, si = value
        return str(round(si * t.per_rad(kind == "vel")))
    if value == "increments":
        return str(t.increments)
    if value == "feed":
        return str(t.feed or 1)
    return str(value)


def catalog(t: Units) -> dict[int, Obj]:
    """The CiA 402 objects of the tables above.

    Parameters
    ----------
    t : Units
        The twin whose defaults and unit codes they take.

    Returns
    -------
    dict
        The objects by index.
    """
    out = {
        i: var(i, Var(name, dtype, access, _default(t, d), pdo))
        for i, (name, dtype, access, pdo, d) in _VARIABLES.items()
    }
    for i, (name, kind, subs) in _RECORDS.items():
        entries = [
            (sub, Var(n, dtype, access[0] if access else "rw", _default(t, d), pdo))
            for sub, n, dtype, pdo, d, *access in subs
        ]
        out[i] = record(i, name, entries, kind=kind)
    out[0x60A8] = var(0x60A8, Var("SI unit position", UINT32, "rw", f"0x{t.position_unit:08X}"))
    out[0x60A9] = var(0x60A9, Var("SI unit velocity", UINT32, "rw", f"0x{t.velocity_unit:08X}"))
    return out
