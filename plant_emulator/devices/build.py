"""Writes the EDS files of the emulator's zoo of drives from the tables below.

Run ``python -m plant_emulator.devices.build`` after changing a table; a test checks that
the committed files are what this module writes. Each drive's profile (``<name>.toml``,
written by hand) says what the EDS cannot, and in ``modelled_on`` which published facts the
twin follows and which of its features are variants not confirmed for the real drive.

The tables are written here from published facts (which objects a drive has, their access
and mappability, PDO counts and default mappings, units, manufacturer objects); the object
names are CiA 402's. Nothing is taken from a vendor's file. Defaults given in SI below are
converted to each drive's own units.

A drive of several axes (``Twin.axes``) has each axis's objects as CiA 301 and 402 lay out a
module of several logical devices (``drivers.maps.logical``): axis n's 0x800 (n - 1) above
axis 1's, named with their axis (``Controlword axis 2``), each axis's device type at 0x67FF +
0x800 (n - 1), and 0x1000's additional information FFFFh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from drivers.maps.eds_writer import (
    INT8,
    INT32,
    UINT8,
    UINT16,
    UINT32,
    DeviceInfo,
    Obj,
    Var,
    cia301_objects,
    eds_text,
    mapped,
    pdo_objects,
    var,
)
from drivers.maps.logical import AXIS_OFFSET, DEVICE_TYPE_OF_AXIS, MULTIPLE_DEVICES, axis_object
from plant_emulator.devices.catalog import catalog as make_catalog

__all__ = ["ZOO", "Twin", "eds_of", "write_all"]

HERE = Path(__file__).resolve().parent

CW, SW = mapped(0x6040, 0, 16), mapped(0x6041, 0, 16)
MODE, MODE_DISP = mapped(0x6060, 0, 8), mapped(0x6061, 0, 8)
TARGET_POS, TARGET_VEL, TARGET_TQ = mapped(0x607A, 0, 32), mapped(0x60FF, 0, 32), mapped(0x6071, 0, 16)
POS, VEL, TQ = mapped(0x6064, 0, 32), mapped(0x606C, 0, 32), mapped(0x6077, 0, 16)
INPUTS = mapped(0x60FD, 0, 32)

#: 0x6502 bits
PP, PV, HM, IP, CSP, CSV, CST = 1 << 0, 1 << 2, 1 << 5, 1 << 6, 1 << 7, 1 << 8, 1 << 9
#: the objects of interpolated position (ip): sub-mode, data record, time period, sync definition,
#: buffer; and the position demand 0x6062
_IP_OBJECTS = frozenset({0x60C0, 0x60C1, 0x60C2, 0x60C3, 0x60C4, 0x6062})


@dataclass(frozen=True)
class Twin:
    """One zoo drive: identity, PDOs, which optional objects it has and its units."""

    info: DeviceInfo  #: its [DeviceInfo]
    device_type: int  #: 0x1000
    modes: int  #: 0x6502 (0: the drive has no 0x6502)
    rpdo: tuple[tuple[int, ...], ...]  #: default mappings
    tpdo: tuple[tuple[int, ...], ...]  #: default mappings
    rpdo_types: tuple[int, ...]  #: the RPDOs' transmission types
    tpdo_types: tuple[int, ...]  #: the TPDOs' transmission types
    objects: frozenset[int]  #: the optional CiA 402 objects it has (see ``plant_emulator.devices.catalog``)
    increments: int  #: per motor revolution (0x608F where it has one)
    position_unit: int = 0  #: 0x60A8 default (0: no 0x60A8)
    velocity_unit: int = 0  #: 0x60A9 default (0: no 0x60A9)
    feed: int = 0  #: 0x6092 sub 1 (0: no 0x6092)
    fixed_mapping: bool = False  #: its PDO mappings cannot be written
    rpdo_subs: tuple[int, ...] = (1, 2, 3, 5)  #: sub-indices of an RPDO communication record
    manufacturer: tuple[Obj, ...] = ()  #: its objects in 0x2000-0x5FFF
    access: tuple[tuple[int, str], ...] = ()  #: (index, AccessType) overriding CiA 402's
    names: tuple[tuple[int, str], ...] = ()  #: (index, ParameterName) overriding CiA 402's
    heartbeat_ms: int = 0  #: 0x1017 default
    axes: int = 1  #: logical devices (axes), each with the objects above (module docstring)
    store: bool = True  #: 0x1010/0x1011: it stores its parameters on command

    def per_rad(self, velocity: bool) -> float:
        """Device units per rad (or per rad/s), as ``drivers.maps.units`` reads them.

        Parameters
        ----------
        velocity : bool
            Per rad/s (else per rad).

        Returns
        -------
        float
            Device units.
        """
        from drivers.maps.units import position_per_revolution, velocity_per_revolution

        feed = float(self.feed) if self.feed else None
        if velocity:
            per_rev = velocity_per_revolution(
                self.increments, feed=feed, unit=self.velocity_unit, position_unit=self.position_unit
            )
        else:
            per_rev = position_per_revolution(self.increments, feed=feed, unit=self.position_unit)
        return per_rev / (2.0 * math.pi)


#: objects every zoo drive has
_ALWAYS = (
    (0x6040, Var("Controlword", UINT16, "rw", "0", True)),
    (0x6041, Var("Statusword", UINT16, "ro", "0", True)),
    (0x6060, Var("Modes of operation", INT8, "rw", "0", True)),
    (0x6061, Var("Modes of operation display", INT8, "ro", "0", True)),
    (0x6064, Var("Position actual value", INT32, "ro", "0", True)),
    (0x606C, Var("Velocity actual value", INT32, "ro", "0", True)),
    (0x607A, Var("Target position", INT32, "rw", "0", True)),
    (0x60FF, Var("Target velocity", INT32, "rw", "0", True)),
)


def _comm(t: Twin, name: str) -> list[Obj]:
    info = t.info
    device_type = t.device_type if t.axes == 1 else MULTIPLE_DEVICES << 16 | t.device_type & 0xFFFF
    objs = cia301_objects(
        device_type=device_type,
        name=name,
        vendor=info.vendor_number,
        product=info.product_number,
        heartbeat_ms=t.heartbeat_ms,
        consumers=2,
        store=t.store,
    )
    return objs + pdo_objects(
        t.rpdo,
        t.tpdo,
        rpdo_types=t.rpdo_types,
        tpdo_types=t.tpdo_types,
        rpdo_enabled=[True] * len(t.rpdo),
        tpdo_enabled=[bool(e) for e in t.tpdo],
        rpdo_subs=t.rpdo_subs,
        access="const" if t.fixed_mapping else "rw",
    )


def _objects(t: Twin, name: str) -> list[Obj]:
    catalog = make_catalog(t)
    access, names = dict(t.access), dict(t.names)
    objs = _comm(t, name) + list(t.manufacturer)
    objs += [var(index, v) for index, v in _ALWAYS]
    objs += [catalog[i] for i in sorted(t.objects)]
    if t.modes:
        objs.append(var(0x6502, Var("Supported drive modes", UINT32, "ro", f"0x{t.modes:08X}")))
    objs = [_override(o, access.get(o.index), names.get(o.index)) for o in objs]
    if t.axes == 1:
        return objs
    axis_1 = [o for o in objs if 0x6000 <= o.index < 0x6000 + AXIS_OFFSET]
    kind = Var("Device type", UINT32, "ro", f"0x{t.device_type:08X}")
    axis_1.append(var(DEVICE_TYPE_OF_AXIS, kind))
    objs.append(var(DEVICE_TYPE_OF_AXIS, kind))
    for n in range(2, t.axes + 1):
        objs += [_on_axis(o, n) for o in axis_1]
    return sorted(objs, key=lambda o: o.index)


def _on_axis(o: Obj, n: int) -> Obj:
    """Axis 1's object ``o`` as axis ``n``'s: 0x800 (n - 1) higher, its name saying the axis."""
    name = f"{o.name} axis {n}"
    subs = tuple((sub, Var(name, *_rest(v))) if o.kind == 0x7 else (sub, v) for sub, v in o.subs)
    return Obj(axis_object(o.index, n), name, subs, o.kind)


def _rest(v: Var) -> tuple[int, str, str, bool]:
    return v.data_type, v.access, v.default, v.pdo


def _override(o: Obj, access: str | None, name: str | None) -> Obj:
    if o.kind != 0x7 or (access is None and name is None):
        return o
    v = o.subs[0][1]
    v = Var(name or v.name, v.data_type, access or v.access, v.default, v.pdo)
    return Obj(o.index, v.name, ((0, v),), 0x7)


def _twin(**kw: object) -> Twin:
    return Twin(**kw)  # type: ignore[arg-type]


_SERVO = frozenset(
    {0x6007, 0x603F, 0x605A, 0x605D, 0x605E, 0x6065, 0x6066, 0x6071, 0x6072, 0x6073, 0x6075, 0x6076, 0x6077}
    | {0x6078, 0x607C, 0x607D, 0x6080, 0x6081, 0x6083, 0x6084, 0x6085, 0x608F, 0x6098, 0x6099, 0x609A}
    | {0x60F4, 0x60FD}
)
_NO_TORQUE = _SERVO - {0x6071, 0x6072, 0x6073, 0x6075, 0x6076, 0x6077, 0x6078}

ZOO: dict[str, Twin] = {
    "epos4": _twin(
        info=DeviceInfo(
            "maxon motor ag",
            0xFB,
            "EPOS4 twin",
            0x65520000,
            "twin of a maxon EPOS4 (drive-rig zoo)",
            baud_rates=(20, 50, 125, 250, 500, 800, 1000),
            lss=True,  # its node-ID and bit rate set by LSS (maxon's EPOS4 Communication Guide, 3.5)
        ),
        device_type=0x00020192,
        modes=PP | PV | HM | CSP | CSV | CST,
        rpdo=((CW, MODE), (CW, TARGET_POS), (CW, TARGET_VEL), (CW, TARGET_TQ)),
        tpdo=((SW, MODE_DISP), (SW, POS), (SW, VEL), (SW, TQ)),
        rpdo_types=(255, 255, 255, 255),
        tpdo_types=(255, 255, 255, 255),
        objects=_SERVO | {0x60A9},
        increments=4096,
        velocity_unit=0x00B44700,  # rpm
        manufacturer=(
            var(0x2000, Var("Node-ID", UINT8, "rw", "1")),
            var(0x2001, Var("CAN bit rate", UINT16, "rw", "0")),  # 0 = 1 Mbit/s ... 9 = automatic
        ),
    ),
    "nanotec-c5e": _twin(
        info=DeviceInfo(
            "Nanotec Electronic GmbH & Co. KG",
            0x26C,
            "C5-E twin",
            0x10,
            "twin of a Nanotec C5-E (drive-rig zoo)",
        ),
        device_type=0x00060192,
        modes=PP | PV | HM | CSP | CSV | CST,
        rpdo=((CW, MODE), (CW, TARGET_POS), (CW, TARGET_VEL), (CW, TARGET_TQ)),
        tpdo=((SW, MODE_DISP), (SW, POS), (SW, VEL), (SW, TQ)),
        rpdo_types=(255, 255, 255, 255),
        tpdo_types=(255, 255, 255, 255),
        objects=_SERVO | {0x6091, 0x6092, 0x60A8, 0x60A9},
        increments=4000,
        position_unit=0xFF410000,  # a tenth of a degree
        velocity_unit=0x00B44700,  # rpm
        feed=1,
    ),
    "tmcm-1160": _twin(
        info=DeviceInfo(
            "TRINAMIC Motion Control GmbH & Co. KG",
            0x286,
            "TMCM-1160 twin",
            1160,
            "twin of a TRINAMIC TMCM-1160 stepper module (drive-rig zoo)",
        ),
        device_type=0x00020192,
        modes=PP | PV | HM | CSP | CSV,
        rpdo=((CW,), (CW, MODE), (CW, TARGET_POS), (CW, TARGET_VEL)),
        tpdo=((SW,), (SW, MODE_DISP), (SW, POS), (SW, VEL)),
        rpdo_types=(255, 255, 255, 254),
        tpdo_types=(255, 255, 255, 255),
        objects=_NO_TORQUE - {0x608F},
        increments=51200,  # 200 full steps x 256 microsteps (the profile says so: no 0x608F)
        rpdo_subs=(1, 2),
    ),
    "faulhaber-mc5004": _twin(
        info=DeviceInfo(
            "Dr. Fritz Faulhaber GmbH & Co. KG",
            0x147,
            "MC 5004 twin",
            0x5004,
            "twin of a FAULHABER MC 5004 motion controller (drive-rig zoo)",
        ),
        device_type=0x00020192,
        modes=PP | PV | HM | CSP | CSV | CST,
        rpdo=((CW,), (CW, TARGET_POS), (CW, TARGET_VEL), (CW, TARGET_TQ)),
        tpdo=((SW,), (SW, POS), (SW, VEL), (SW, TQ)),
        rpdo_types=(255, 255, 255, 255),
        tpdo_types=(255, 255, 255, 255),
        objects=_SERVO | {0x6091, 0x6092},
        increments=4096,
        feed=4096,  # the feed constant in increments: a position unit is one increment
    ),
    "erl-pcs": _twin(
        info=DeviceInfo(
            "ERL Elektronik", 0, "PCS twin", 0, "twin of an ERL PCS drive, static PDO mapping (drive-rig zoo)"
        ),
        device_type=0x00020192,
        modes=PP | PV | HM | CSP | CSV,
        rpdo=((CW, mapped(0x60FE, 1, 32)), (CW, MODE), (CW, TARGET_POS), (CW, TARGET_VEL)),
        tpdo=((SW, INPUTS), (SW, MODE_DISP), (SW, POS), (SW, VEL)),
        rpdo_types=(1, 1, 1, 1),
        tpdo_types=(1, 1, 1, 1),
        objects=_NO_TORQUE | {0x60FE},
        increments=4096,
        fixed_mapping=True,
    ),
    "kollmorgen-s300": _twin(
        info=DeviceInfo("Kollmorgen", 0x6A, "S306 twin", 306, "twin of a Kollmorgen S300 (drive-rig zoo)"),
        device_type=0x00020192,
        modes=PP | PV | HM | CSP | CSV | CST,
        rpdo=((CW,), (CW, MODE), (CW, TARGET_POS), (CW, TARGET_VEL)),
        tpdo=((SW,), (SW, MODE_DISP), (SW, POS), (SW, VEL)),
        rpdo_types=(255, 255, 255, 255),
        tpdo_types=(255, 255, 255, 255),
        objects=_SERVO,
        increments=1 << 20,
        names=(
            (0x6076, "Motor rated torque (mN\u00b7m)"),
            (0x6077, "Torque actual value (\u2030 of rated torque)"),
            (0x6080, "Max motor speed (U/min, Drehzahl-\u00dcberwachung)"),
        ),
    ),
    "dual-axis": _twin(
        info=DeviceInfo(
            "drive-rig",
            0xDB1,
            "dual-axis drive",
            0x2402,
            "a dual-axis CiA 402 servo drive: two motors on one node (drive-rig zoo)",
        ),
        device_type=0x00020192,
        modes=PP | PV | HM | IP | CSP | CSV | CST,
        rpdo=(
            (CW, TARGET_POS),
            (CW, TARGET_VEL),
            (mapped(0x6840, 0, 16), mapped(0x687A, 0, 32)),
            (mapped(0x6840, 0, 16), mapped(0x68FF, 0, 32)),
        ),
        tpdo=((SW, POS), (VEL, TQ), (mapped(0x6841, 0, 16), mapped(0x6864, 0, 32)), (mapped(0x686C, 0, 32),)),
        rpdo_types=(1, 1, 1, 1),
        tpdo_types=(1, 1, 1, 1),
        objects=_SERVO | _IP_OBJECTS,
        increments=4096,
        axes=2,
    ),
    "compact-2pdo": _twin(
        info=DeviceInfo(
            "drive-rig",
            0xDB1,
            "compact 2+2 PDO drive",
            0x2202,
            "a compact CiA 402 drive: two RPDOs, two TPDOs, 0x6060 write-only (drive-rig zoo)",
        ),
        device_type=0x00020192,
        modes=PP | PV | CSP | CSV | CST,
        rpdo=((CW, MODE, TARGET_POS), (CW, TARGET_VEL, TARGET_TQ)),
        tpdo=((SW, MODE_DISP, POS), (VEL, TQ)),
        rpdo_types=(1, 1),
        tpdo_types=(1, 1),
        objects=_SERVO - {0x6075, 0x6076, 0x6078, 0x6098, 0x6099, 0x609A, 0x60FD, 0x607C},
        increments=2048,
        access=((0x6060, "wo"),),
        store=False,  # a drive that keeps no parameters of its own (0x1010/0x1011 absent)
    ),
}


def eds_of(name: str) -> str:
    """The EDS text of zoo drive ``name``.

    Parameters
    ----------
    name : str
        A zoo drive.

    Returns
    -------
    str
        Its EDS text.
    """
    twin = ZOO[name]
    return eds_text(_objects(twin, twin.info.product_name), f"{name}.eds", twin.info)


#: the drives whose EDS is written in Windows-1252 (as the vendor's own is)
CP1252 = frozenset({"kollmorgen-s300"})


def write_all() -> None:
    """Write every zoo EDS next to this module."""
    for name in ZOO:
        encoding = "cp1252" if name in CP1252 else "ascii"
        (HERE / f"{name}.eds").write_bytes(eds_of(name).encode(encoding))


if __name__ == "__main__":  # pragma: no cover
    write_all()
