"""A CiA 402 drive's whole picture for ``rig drive status``, read from the device by SDO, with
nothing written: who it is (0x1018 with the vendor's name, 0x1008-0x100A), its state with every
statusword bit named in the words of its mode, its mode, its actual position, velocity and
torque, its limits (0x607D, 0x6080, 0x607F, 0x6072, 0x6073), its profile and ramps (0x6081,
0x6083-0x6085), its following-error window (0x6065, 0x6066) and position window (0x6067), its
error register, error code and history (0x1001, 0x603F, 0x1003, each code named) and its
digital inputs (0x60FD). Each object is read by its standard's type whatever the EDS in use
names (``drivers.identity.read_standard``); an object the drive does not have (or refuses) is
left out, never an error. Quantities come in SI and in the drive's own units
(``rig.commission.quantities``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from drivers.errors import RigError
from drivers.identity import read_standard
from drivers.maps import cia
from drivers.maps.emcy import emcy_text
from rig.commission.quantities import quantity

__all__ = ["SECTIONS", "STATUS_BITS", "bit_names", "picture"]

#: statusword bits 0-15 whose meaning is the same in every mode (CiA 402-2); 12 and 13: ``MODE_BITS``
STATUS_BITS = (
    "ready to switch on",
    "switched on",
    "operation enabled",
    "fault",
    "voltage enabled",
    "quick stop (0: active)",
    "switch on disabled",
    "warning",
    "manufacturer specific (8)",
    "remote",
    "target reached",
    "internal limit active",
    "operation mode specific (12)",
    "operation mode specific (13)",
    "manufacturer specific (14)",
    "manufacturer specific (15)",
)
#: bits 12 and 13 in each mode's words (CiA 402-2)
MODE_BITS: dict[int, tuple[str, str]] = {
    1: ("set-point acknowledge", "following error"),
    3: ("speed zero", "max slippage error"),
    4: ("reserved (12)", "reserved (13)"),
    6: ("homing attained", "homing error"),
    7: ("ip mode active", "reserved (13)"),
    8: ("drive follows the command value", "following error"),
    9: ("drive follows the command value", "reserved (13)"),
    10: ("drive follows the command value", "reserved (13)"),
}
#: 0x60FD bits 0-3 (CiA 402-2); 16-31 are the manufacturer's
INPUTS = ("negative limit switch", "positive limit switch", "home switch", "interlock")
_STRINGS = (("device_name", cia.DEVICE_NAME), ("hardware", 0x1009), ("firmware", cia.SOFTWARE_VERSION))
#: the picture's quantity sections: (key, [(name, index, sub)])
SECTIONS: tuple[tuple[str, tuple[tuple[str, int, int], ...]], ...] = (
    (
        "actual",
        (
            ("position", cia.POSITION_ACTUAL, 0),
            ("velocity", cia.VELOCITY_ACTUAL, 0),
            ("torque", cia.TORQUE_ACTUAL, 0),
            ("current", cia.CURRENT_ACTUAL, 0),
        ),
    ),
    (
        "limits",
        (
            ("position min (0x607D:1)", cia.SOFTWARE_POSITION_LIMIT, 1),
            ("position max (0x607D:2)", cia.SOFTWARE_POSITION_LIMIT, 2),
            ("max motor speed (0x6080)", cia.MAX_MOTOR_SPEED, 0),
            ("max profile velocity (0x607F)", 0x607F, 0),
            ("max torque (0x6072)", cia.MAX_TORQUE, 0),
            ("max current (0x6073)", cia.MAX_CURRENT, 0),
        ),
    ),
    (
        "profile",
        (
            ("velocity (0x6081)", cia.PROFILE_VELOCITY, 0),
            ("acceleration (0x6083)", cia.PROFILE_ACCELERATION, 0),
            ("deceleration (0x6084)", cia.PROFILE_DECELERATION, 0),
            ("quick stop deceleration (0x6085)", cia.QUICK_STOP_DECELERATION, 0),
        ),
    ),
    (
        "windows",
        (
            ("following error window (0x6065)", cia.FOLLOWING_ERROR_WINDOW, 0),
            ("following error timeout (0x6066)", cia.FOLLOWING_ERROR_TIMEOUT, 0),
            ("position window (0x6067)", cia.POSITION_WINDOW, 0),
        ),
    ),
)


def bit_names(mode: int | None) -> tuple[str, ...]:
    """The statusword's 16 bits in words, bits 12 and 13 in ``mode``'s (0x6061).

    Parameters
    ----------
    mode : int | None
        0x6061 (None: not known).

    Returns
    -------
    tuple[str, ...]
        16 names.
    """
    twelve, thirteen = MODE_BITS.get(mode if mode is not None else 0, (STATUS_BITS[12], STATUS_BITS[13]))
    return (*STATUS_BITS[:12], twelve, thirteen, *STATUS_BITS[14:])


def _string(upload: Callable[[int, int], bytes], index: int) -> str | None:
    try:
        data = upload(index, 0)
    except RigError:
        return None
    return bytes(data).decode("latin-1").rstrip("\x00").strip() or None


def picture(axis: Any, units: Any, statusword: int, mode: int | None) -> dict[str, Any]:
    """The sections of ``axis``'s picture beside its state: identity strings, bits, quantities,
    errors and inputs (``units``: its ``DriveUnits``; ``statusword`` and ``mode`` as read).

    Parameters
    ----------
    axis : Any
        The drive.
    units : Any
        Its ``DriveUnits``.
    statusword : int
        As read.
    mode : int | None
        0x6061 as read.

    Returns
    -------
    dict[str, Any]
        The sections.
    """
    upload = axis.sdo_upload

    def read(index: int, sub: int = 0) -> int | None:
        return read_standard(upload, index, sub)

    out: dict[str, Any] = {key: _string(upload, index) for key, index in _STRINGS}
    names = bit_names(mode)
    out["bits"] = [{"bit": b, "name": names[b], "set": bool(statusword >> b & 1)} for b in range(16)]
    for section, rows in SECTIONS:
        values = {}
        for name, index, sub in rows:
            raw = read(index, sub)
            q = quantity(units, index, raw) if raw is not None else None
            if q is not None:
                values[name] = q.as_dict()
        out[section] = values
    register = read(cia.ERROR_REGISTER)
    out["error_register"] = None if register is None else f"0x{register:02X}"
    count = read(cia.ERROR_HISTORY, 0) or 0
    history = []
    for sub in range(1, min(count, 16) + 1):
        entry = read(cia.ERROR_HISTORY, sub)
        if entry is not None:
            code = entry & 0xFFFF
            history.append({"code": f"0x{code:04X}", "text": emcy_text(code, axis.emcy_texts)})
    out["error_history"] = history
    inputs = read(cia.DIGITAL_INPUTS)
    out["digital_inputs"] = (
        None
        if inputs is None
        else {
            "raw": f"0x{inputs:08X}",
            "active": [name for b, name in enumerate(INPUTS) if inputs >> b & 1]
            + [f"manufacturer input {b - 16}" for b in range(16, 32) if inputs >> b & 1],
        }
    )
    return out
