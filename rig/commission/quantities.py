"""What a CiA 402 object's number means: its quantity, its unit on the drive and in SI, for a
person (``rig drive status``, ``sdo read``, a move's report).

``QUANTITIES`` gives the kind of the standard objects that hold a quantity (CiA 402-2): a
position, a velocity or an acceleration in the drive's own units (0x608F/0x60A8/0x60A9 ...,
``drivers.cia402_units.DriveUnits``), a torque or a current in per mille of the rated value
(0x6076, 0x6075), a speed in rpm (0x6080), a time in ms, a voltage in mV (the toolkit's 0x2100).
``quantity(units, index, raw)`` gives the value in SI with its unit, and the drive's number with
its unit in words; a quantity whose factor the drive does not give stays in its own units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from drivers.cia402_units import DriveUnits
from drivers.maps import cia

__all__ = ["QUANTITIES", "Quantity", "quantity"]

_RPM = 2.0 * math.pi / 60.0  #: rad/s per rpm

#: index -> kind of the value (sub-indices alike)
QUANTITIES: dict[int, str] = {
    cia.POSITION_ACTUAL: "position",
    cia.TARGET_POSITION: "position",
    cia.SOFTWARE_POSITION_LIMIT: "position",
    cia.FOLLOWING_ERROR_WINDOW: "position",
    cia.POSITION_WINDOW: "position",
    cia.FOLLOWING_ERROR_ACTUAL: "position",
    cia.HOME_OFFSET: "position",
    cia.VELOCITY_ACTUAL: "velocity",
    cia.TARGET_VELOCITY: "velocity",
    cia.VELOCITY_WINDOW: "velocity",
    cia.PROFILE_VELOCITY: "velocity",
    0x607F: "velocity",  # max profile velocity
    cia.HOMING_SPEEDS: "velocity",
    cia.PROFILE_ACCELERATION: "acceleration",
    cia.PROFILE_DECELERATION: "acceleration",
    cia.QUICK_STOP_DECELERATION: "acceleration",
    cia.HOMING_ACCELERATION: "acceleration",
    cia.TARGET_TORQUE: "torque",
    cia.TORQUE_ACTUAL: "torque",
    cia.MAX_TORQUE: "torque",
    cia.CURRENT_ACTUAL: "current",
    cia.MAX_CURRENT: "current",
    cia.MAX_MOTOR_SPEED: "rpm",
    cia.FOLLOWING_ERROR_TIMEOUT: "ms",
    cia.RATED_TORQUE: "mNm",
    cia.RATED_CURRENT: "mA",
    cia.TARGET_VOLTAGE: "mV",
}


@dataclass(frozen=True)
class Quantity:
    """A value in SI (``si``, NaN where no factor is known; ``unit``) and as the drive holds it
    (``raw``, ``raw_unit`` in words)."""

    si: float  #: the value in SI (NaN: no factor known)
    unit: str  #: its SI unit
    raw: int | float  #: as the drive holds it
    raw_unit: str  #: the drive's unit, in words

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (NaN as None).

        Returns
        -------
        dict[str, Any]
            The quantity.
        """
        return {
            "value": None if math.isnan(self.si) else self.si,
            "unit": self.unit,
            "drive_value": self.raw,
            "drive_unit": self.raw_unit,
        }


def _scaled(raw: float, factor: float, unit: str, own: str) -> Quantity:
    """``raw`` / ``factor`` in ``unit``; NaN where the factor is not known."""
    if math.isfinite(factor) and factor:
        return Quantity(raw / factor, unit, raw, f"{own} ({factor:.6g} per {unit})")
    return Quantity(math.nan, unit, raw, f"{own} (no factor to {unit})")


def quantity(units: DriveUnits, index: int, raw: int | float) -> Quantity | None:
    """The quantity object ``index`` holds as ``raw``, or None where it holds none.

    Parameters
    ----------
    units : drivers.cia402_units.DriveUnits
        The drive's units.
    index : int
        The object.
    raw : int | float
        Its value.

    Returns
    -------
    Quantity | None
        The quantity, or None.
    """
    kind = QUANTITIES.get(index)
    if kind == "position":
        return _scaled(raw, units.position, "rad", "position units")
    if kind == "velocity":
        return _scaled(raw, units.velocity, "rad/s", "velocity units")
    if kind == "acceleration":
        return _scaled(raw, units.velocity, "rad/s^2", "velocity units per s")
    if kind == "torque":
        return Quantity(raw / 1000.0 * units.rated_torque, "N m", raw, "per mille of the rated torque")
    if kind == "current":
        return Quantity(raw / 1000.0 * units.rated_current, "A", raw, "per mille of the rated current")
    if kind == "rpm":
        return Quantity(raw * _RPM, "rad/s", raw, "rpm")
    if kind == "ms":
        return Quantity(raw / 1000.0, "s", raw, "ms")
    if kind == "mNm":
        return Quantity(raw / 1000.0, "N m", raw, "mN m")
    if kind == "mA":
        return Quantity(raw / 1000.0, "A", raw, "mA")
    if kind == "mV":
        return Quantity(raw / 1000.0, "V", raw, "mV")
    return None
