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

0x60C5/0x60C6 (max acceleration/deceleration) are read-only here: the emulated drive writes the
most its motor can do there (``plant_emulator.process_image.Ratings``; 0: not said), a limit it
never needs to enforce.
"""

from __future__ import annotations

import pathlib

from drivers.maps.eds_writer import (
    INT8,
    INT16,
    INT32,
    UINT16,
    UINT32,
    DeviceInfo,
    Obj,
    Var,
    cia301_objects,
    eds_text,
    pdo_objects,
    record,
    var,
)
from drivers.maps.eds_writer import mapped as _m

__all__ = ["CIA402_DRIVE", "CIA406_ENCODER", "FILES", "eds_of", "write_all"]

HERE = pathlib.Path(__file__).resolve().parent
VENDOR = 0x00000DB1  #: the toolkit's vendor id in its EDS files


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
    objs = cia301_objects(
        device_type=device_type,
        name=name,
        vendor=VENDOR,
        product=product,
        heartbeat_ms=100,
        consumers=4,
        software="drive-rig emulator 1",
        store=device_type & 0xFFFF == 402,  # the drive stores its parameters; the encoder, none
    )
    return objs + pdo_objects(
        rpdo,
        tpdo,
        rpdo_types=rpdo_types,
        tpdo_types=tpdo_types,
        rpdo_enabled=[bool(r) for r in rpdo],
        tpdo_enabled=tpdo_enabled,
    )


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
    var(0x60C5, Var("Max acceleration", UINT32, "ro", "0")),
    var(0x60C6, Var("Max deceleration", UINT32, "ro", "0")),
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


FILES = {"cia402_drive": CIA402_DRIVE, "cia406_encoder": CIA406_ENCODER}


def eds_of(name: str) -> str:
    """The EDS text of one of the toolkit's devices.

    Parameters
    ----------
    name : str
        The device, a key of ``FILES``.

    Returns
    -------
    str
        The EDS file's text.
    """
    info = DeviceInfo(
        "drive-rig",
        VENDOR,
        name,
        0x402 if name == "cia402_drive" else 0x406,
        f"drive-rig {name}; generated by drivers/maps/build_eds.py",
        baud_rates=(250, 500, 1000),
        lss=True,  # the emulated devices answer LSS (plant_emulator.lss_slave)
    )
    return eds_text(FILES[name], f"{name}.eds", info)


def write_all() -> None:
    """Write every EDS of ``FILES`` next to this module."""
    for name in FILES:
        (HERE / f"{name}.eds").write_text(eds_of(name))


if __name__ == "__main__":  # pragma: no cover
    write_all()
