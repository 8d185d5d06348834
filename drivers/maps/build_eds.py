"""Writes the EDS files of this directory (CiA 306 format) from one table per device.

Run ``python -m drivers.maps.build_eds`` after changing a table; a test checks
that the committed files equal what this module writes, so the device (the
emulator) and the driver always read the same definition.

Object indices follow CiA 301 (communication), CiA 402 (drives) and CiA 406
(encoders). Manufacturer objects (0x2000-0x5FFF) of the emulated drive:

- 0x2001 command latency [us]: an RPDO with transmission type 254/255 is applied
  this long after it is received (the s-PWM-middle case); a synchronous RPDO
  (type 0-240) is applied at the next SYNC (the s-PWM-start case).
- 0x2100 target voltage [mV]: the armature voltage u of the DC-motor papers in
  the manufacturer-specific mode -1 (voltage mode).
- 0x2200 dq voltage reference [mV] (sub 1 d, sub 2 q), 0x2210 dq current [mA]
  (sub 1 d, sub 2 q), 0x2220 frame angle [urad], 0x2221 frame speed [mrad/s]:
  the grid-converter preset, mode -2 (dq voltage mode).
"""

from __future__ import annotations

import pathlib
from dataclasses import dataclass

__all__ = ["CIA402_DRIVE", "CIA406_ENCODER", "eds_text", "write_all"]

HERE = pathlib.Path(__file__).resolve().parent

# CiA 301 data types
BOOLEAN, INT8, INT16, INT32, UINT8, UINT16, UINT32, VSTRING = 0x1, 0x2, 0x3, 0x4, 0x5, 0x6, 0x7, 0x9


@dataclass(frozen=True)
class Var:
    """One variable: (sub)index, name, type, access, default, PDO mappable."""

    name: str
    data_type: int
    access: str = "rw"
    default: str = "0"
    pdo: bool = False


@dataclass(frozen=True)
class Obj:
    """One object: a VAR (one entry in ``subs`` at subindex 0) or a RECORD/ARRAY."""

    index: int
    name: str
    subs: tuple[tuple[int, Var], ...]
    kind: int = 0x9  # 0x7 VAR, 0x8 ARRAY, 0x9 RECORD


def var(index: int, v: Var) -> Obj:
    return Obj(index, v.name, ((0, v),), 0x7)


def record(index: int, name: str, entries: list[tuple[int, Var]], *, kind: int = 0x9) -> Obj:
    highest = max(s for s, _ in entries)
    return Obj(
        index, name, ((0, Var("Highest sub-index supported", UINT8, "ro", str(highest))), *entries), kind
    )


def _pdo_comm(index: int, kind: str, n: int, *, enabled: bool, ttype: int) -> Obj:
    base = (0x200 if kind == "R" else 0x180) + 0x100 * n
    cob = f"$NODEID+0x{base:X}" if enabled else f"$NODEID+0x{0x80000000 + base:X}"
    entries = [
        (1, Var("COB-ID", UINT32, "rw", cob)),
        (2, Var("Transmission type", UINT8, "rw", str(ttype))),
        (3, Var("Inhibit time", UINT16, "rw", "0")),
        (5, Var("Event timer", UINT16, "rw", "0")),
    ]
    if kind == "T":
        entries.append((6, Var("SYNC start value", UINT8, "rw", "0")))
    return record(index, f"{kind}PDO{n + 1} communication parameter", entries)


def _pdo_map(index: int, kind: str, n: int, mapped: list[int]) -> Obj:
    entries = [
        (s + 1, Var(f"Mapped object {s + 1}", UINT32, "rw", f"0x{m:08X}")) for s, m in enumerate(mapped)
    ]
    entries += [
        (s + 1, Var(f"Mapped object {s + 1}", UINT32, "rw", "0x00000000")) for s in range(len(mapped), 8)
    ]
    obj = record(index, f"{kind}PDO{n + 1} mapping parameter", entries)
    head = (0, Var("Number of mapped objects", UINT8, "rw", str(len(mapped))))
    return Obj(obj.index, obj.name, (head, *obj.subs[1:]), obj.kind)


def _m(index: int, sub: int, bits: int) -> int:
    return (index << 16) | (sub << 8) | bits


def _comm_objects(
    device_type: int,
    name: str,
    product: int,
    *,
    rpdo: list[list[int]],
    tpdo: list[list[int]],
    tpdo_types: list[int],
    rpdo_types: list[int],
    tpdo_enabled: list[bool],
) -> list[Obj]:
    objs = [
        var(0x1000, Var("Device type", UINT32, "ro", f"0x{device_type:08X}")),
        var(0x1001, Var("Error register", UINT8, "ro", "0", pdo=True)),
        var(0x1005, Var("COB-ID SYNC", UINT32, "rw", "0x00000080")),
        var(0x1008, Var("Manufacturer device name", VSTRING, "const", name)),
        var(0x100A, Var("Manufacturer software version", VSTRING, "const", "drive-rig emulator 1")),
        var(0x1014, Var("COB-ID EMCY", UINT32, "ro", "$NODEID+0x80")),
        record(
            0x1016,
            "Consumer heartbeat time",
            [(s, Var(f"Consumer heartbeat time {s}", UINT32, "rw", "0")) for s in (1, 2, 3, 4)],
            kind=0x8,
        ),
        var(0x1017, Var("Producer heartbeat time", UINT16, "rw", "100")),
        record(
            0x1018,
            "Identity object",
            [
                (1, Var("Vendor-ID", UINT32, "ro", "0x00000DB1")),
                (2, Var("Product code", UINT32, "ro", f"0x{product:08X}")),
                (3, Var("Revision number", UINT32, "ro", "0x00010000")),
                (4, Var("Serial number", UINT32, "ro", "0x00000001")),
            ],
        ),
    ]
    objs.append(
        record(0x1029, "Error behavior", [(1, Var("Communication error", UINT8, "rw", "0"))], kind=0x8)
    )
    for n in range(4):
        objs.append(_pdo_comm(0x1400 + n, "R", n, enabled=bool(rpdo[n]), ttype=rpdo_types[n]))
    for n in range(4):
        objs.append(_pdo_map(0x1600 + n, "R", n, rpdo[n]))
    for n in range(4):
        objs.append(_pdo_comm(0x1800 + n, "T", n, enabled=tpdo_enabled[n], ttype=tpdo_types[n]))
    for n in range(4):
        objs.append(_pdo_map(0x1A00 + n, "T", n, tpdo[n]))
    return objs


CW, SW, MODE, MODE_DISP = _m(0x6040, 0, 16), _m(0x6041, 0, 16), _m(0x6060, 0, 8), _m(0x6061, 0, 8)

CIA402_DRIVE: list[Obj] = [
    *_comm_objects(
        0x00020192,
        "drive-rig emulated servo drive",
        0x402,
        rpdo=[
            [CW, _m(0x2100, 0, 32)],
            [CW, _m(0x607A, 0, 32)],
            [CW, _m(0x60FF, 0, 32)],
            [CW, _m(0x6071, 0, 16), MODE],
        ],
        rpdo_types=[1, 1, 1, 1],
        tpdo=[
            [SW, MODE_DISP],
            [_m(0x6064, 0, 32), _m(0x606C, 0, 32)],
            [SW, _m(0x6077, 0, 16), _m(0x6078, 0, 16)],
            [_m(0x2210, 1, 32), _m(0x2210, 2, 32)],
        ],
        tpdo_types=[255, 1, 1, 1],
        tpdo_enabled=[True, True, True, False],
    ),
    var(0x2001, Var("Command latency us", UINT32, "rw", "0")),
    var(0x2100, Var("Target voltage mV", INT32, "rw", "0", pdo=True)),
    record(
        0x2200,
        "dq voltage reference mV",
        [(1, Var("u_d", INT32, "rw", "0", pdo=True)), (2, Var("u_q", INT32, "rw", "0", pdo=True))],
    ),
    record(
        0x2210,
        "dq current mA",
        [(1, Var("i_d", INT32, "ro", "0", pdo=True)), (2, Var("i_q", INT32, "ro", "0", pdo=True))],
    ),
    var(0x2220, Var("Frame angle urad", INT32, "ro", "0", pdo=True)),
    var(0x2221, Var("Frame speed mrad/s", INT32, "ro", "0", pdo=True)),
    var(0x6007, Var("Abort connection option code", INT16, "rw", "1")),
    var(0x603F, Var("Error code", UINT16, "ro", "0", pdo=True)),
    var(0x6040, Var("Controlword", UINT16, "rw", "0", pdo=True)),
    var(0x6041, Var("Statusword", UINT16, "ro", "0", pdo=True)),
    var(0x605A, Var("Quick stop option code", INT16, "rw", "2")),
    var(0x605E, Var("Fault reaction option code", INT16, "rw", "2")),
    var(0x6060, Var("Modes of operation", INT8, "rw", "0", pdo=True)),
    var(0x6061, Var("Modes of operation display", INT8, "ro", "0", pdo=True)),
    var(0x6064, Var("Position actual value", INT32, "ro", "0", pdo=True)),
    var(0x6065, Var("Following error window", UINT32, "rw", "4096")),
    var(0x606C, Var("Velocity actual value", INT32, "ro", "0", pdo=True)),
    var(0x6071, Var("Target torque", INT16, "rw", "0", pdo=True)),
    var(0x6073, Var("Max current", UINT16, "rw", "3000")),
    var(0x6075, Var("Motor rated current", UINT32, "rw", "10000")),
    var(0x6076, Var("Motor rated torque", UINT32, "rw", "1000")),
    var(0x6077, Var("Torque actual value", INT16, "ro", "0", pdo=True)),
    var(0x6078, Var("Current actual value", INT16, "ro", "0", pdo=True)),
    var(0x607A, Var("Target position", INT32, "rw", "0", pdo=True)),
    var(0x6080, Var("Max motor speed", UINT32, "rw", "6000")),
    var(0x6083, Var("Profile acceleration", UINT32, "rw", "500000", pdo=True)),
    var(0x6084, Var("Profile deceleration", UINT32, "rw", "500000", pdo=True)),
    var(0x6085, Var("Quick stop deceleration", UINT32, "rw", "1000000", pdo=True)),
    record(
        0x608F,
        "Position encoder resolution",
        [
            (1, Var("Encoder increments", UINT32, "rw", "4096")),
            (2, Var("Motor revolutions", UINT32, "rw", "1")),
        ],
    ),
    var(0x60F4, Var("Following error actual value", INT32, "ro", "0", pdo=True)),
    var(0x60FF, Var("Target velocity", INT32, "rw", "0", pdo=True)),
    var(0x6502, Var("Supported drive modes", UINT32, "ro", "0x00030384")),
]

CIA406_ENCODER: list[Obj] = [
    *_comm_objects(
        0x00010196,
        "drive-rig emulated rotary encoder",
        0x406,
        rpdo=[[], [], [], []],
        rpdo_types=[255, 255, 255, 255],
        tpdo=[[_m(0x6004, 0, 32)], [_m(0x6004, 0, 32), _m(0x6030, 1, 16)], [], []],
        tpdo_types=[254, 1, 1, 1],
        tpdo_enabled=[True, True, False, False],
    ),
    var(0x6000, Var("Operating parameters", UINT16, "rw", "0")),
    var(0x6001, Var("Measuring units per revolution", UINT32, "rw", "4096")),
    var(0x6004, Var("Position value", UINT32, "ro", "0", pdo=True)),
    record(0x6030, "Speed value", [(1, Var("Speed value channel 1", INT16, "ro", "0", pdo=True))], kind=0x8),
    var(0x6200, Var("Cyclic timer", UINT16, "rw", "0")),
    var(0x6501, Var("Singleturn resolution", UINT32, "ro", "4096")),
]


def eds_text(objs: list[Obj], name: str) -> str:
    """The EDS (CiA 306) text of ``objs``."""
    out = [
        "[FileInfo]",
        f"FileName={name}.eds",
        "FileVersion=1",
        "FileRevision=0",
        "EDSVersion=4.0",
        f"Description=drive-rig {name}; generated by drivers/maps/build_eds.py",
        "CreatedBy=drive-rig",
        "",
        "[DeviceInfo]",
        "VendorName=drive-rig",
        "VendorNumber=0x00000DB1",
        f"ProductName={name}",
        "BaudRate_250=1",
        "BaudRate_500=1",
        "BaudRate_1000=1",
        "SimpleBootUpSlave=1",
        "Granularity=8",
        "NrOfRXPDO=4",
        "NrOfTXPDO=4",
        "LSS_Supported=0",
        "",
    ]
    mandatory = (0x1000, 0x1001, 0x1018)
    groups = {
        "MandatoryObjects": [o for o in objs if o.index in mandatory],
        "OptionalObjects": [o for o in objs if o.index not in mandatory and not 0x2000 <= o.index < 0x6000],
        "ManufacturerObjects": [o for o in objs if 0x2000 <= o.index < 0x6000],
    }
    for section, members in groups.items():
        out.append(f"[{section}]")
        out.append(f"SupportedObjects={len(members)}")
        out += [f"{n + 1}=0x{o.index:04X}" for n, o in enumerate(members)]
        out.append("")
    for o in objs:
        if o.kind == 0x7:
            out += [f"[{o.index:04X}]", *_var_lines(o.subs[0][1]), ""]
            continue
        out += [f"[{o.index:04X}]", f"ParameterName={o.name}", f"ObjectType=0x{o.kind:X}"]
        out += [f"SubNumber={len(o.subs)}", ""]
        for sub, v in o.subs:
            out += [f"[{o.index:04X}sub{sub:X}]", *_var_lines(v), ""]
    return "\n".join(out)


def _var_lines(v: Var) -> list[str]:
    return [
        f"ParameterName={v.name}",
        "ObjectType=0x7",
        f"DataType=0x{v.data_type:04X}",
        f"AccessType={v.access}",
        f"DefaultValue={v.default}",
        f"PDOMapping={int(v.pdo)}",
    ]


FILES = {"cia402_drive": CIA402_DRIVE, "cia406_encoder": CIA406_ENCODER}


def write_all() -> None:
    """Write every EDS of ``FILES`` next to this module."""
    for name, objs in FILES.items():
        (HERE / f"{name}.eds").write_text(eds_text(objs, name))


if __name__ == "__main__":  # pragma: no cover
    write_all()
