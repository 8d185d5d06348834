"""A CiA 402 drive's units, as the host finds them: from the drive's objects, else from configuration.

The drive tells what it can: 0x608F (increments per motor revolution), 0x6091 (gear),
0x6092 (feed constant), 0x60A8/0x60A9 (SI unit codes of position and velocity), or the older
notation and dimension indices 0x6089-0x608C where it has no 0x60A8/0x60A9, 0x6076 (rated
torque, mN m) and 0x6075 (rated current, mA); ``drivers.maps.units`` turns them into factors.
A drive without a position 0x6064 (a velocity-only drive) needs no position factor. What the
drive lacks comes from the axis's ``[axis.units]``:
``counts_per_rev``, ``position_unit``/``velocity_unit`` (SI unit codes), ``rated_torque``
[N m], ``rated_current`` [A]. A factor that the mode needs and nobody gives is a
ConfigError naming the object and the key to set.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from drivers.errors import ConfigError
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.maps.units import (
    INCREMENTS,
    SiUnit,
    dimension_unit,
    position_per_revolution,
    velocity_per_revolution,
)

__all__ = ["DriveUnits", "discover_units", "require"]

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class DriveUnits:
    """Device unit <-> SI factors (NaN: unknown): ``position`` units per rad, ``velocity`` units
    per rad/s, ``rated_torque`` [N m] and ``rated_current`` [A] (torque and current are per mille
    of them); ``source`` says where each came from."""

    position: float  #: position units per rad
    velocity: float  #: velocity units per rad/s
    rated_torque: float  #: [N m] 0x6076
    rated_current: float  #: [A] 0x6075
    source: Mapping[str, str]  #: where each factor came from (an object, ``[axis.units]``)

    @property
    def counts_per_rad(self) -> float:
        """Position units per rad (an older name: increments for drives without a unit code)."""
        return self.position

    def command_raw(self, mode: int, value: float) -> int:
        """The raw target value of an SI command.

        Parameters
        ----------
        mode : int
            The mode (its target's unit).
        value : float
            The command in SI ([V], [N m], [rad/s] or [rad]).

        Returns
        -------
        int
            The target in the drive's units.
        """
        if mode == Mode.VOLTAGE:
            return round(value * 1000.0)  # V -> mV
        if mode == Mode.CST:
            return round(value / self.rated_torque * 1000.0)  # N m -> per mille
        if mode in (Mode.CSV, Mode.PROFILE_VELOCITY):
            return round(value * self.velocity)
        return round(value * self.position)  # rad -> position units

    def quanta(self) -> tuple[float, float]:
        """One position unit [rad] and one velocity unit [rad/s] (0 where not known).

        Returns
        -------
        tuple of (float, float)
            [rad] and [rad/s].
        """
        p, v = self.position, self.velocity
        return (1.0 / p if math.isfinite(p) and p else 0.0, 1.0 / v if math.isfinite(v) and v else 0.0)

    def describe(self) -> dict[str, Any]:
        """The units in force, for status reports.

        Returns
        -------
        dict
            The four factors and where each came from.
        """
        return {
            "position_units_per_rad": self.position,
            "velocity_units_per_rad_s": self.velocity,
            "rated_torque_nm": self.rated_torque,
            "rated_current_a": self.rated_current,
            "from": dict(self.source),
        }


#: the factor each mode's command needs: (DriveUnits field, object, [axis.units] key)
NEEDS = {
    Mode.CST: ("rated_torque", cia.RATED_TORQUE, "rated_torque"),
    Mode.CSV: ("velocity", cia.POSITION_ENCODER_RESOLUTION, "counts_per_rev"),
    Mode.PROFILE_VELOCITY: ("velocity", cia.POSITION_ENCODER_RESOLUTION, "counts_per_rev"),
    Mode.CSP: ("position", cia.POSITION_ENCODER_RESOLUTION, "counts_per_rev"),
    Mode.INTERPOLATED_POSITION: ("position", cia.POSITION_ENCODER_RESOLUTION, "counts_per_rev"),
}


def _ratio(read: Callable[[int, int], Any], index: int) -> float | None:
    num, den = read(index, 1), read(index, 2)
    if num is None or den in (None, 0):
        return None
    return float(num) / float(den)


def discover_units(
    read: Callable[[int, int], Any],
    given: Mapping[str, float],
    *,
    where: str,
    mode: int,
    hint: str = "[axis.units] {key}",
    has_position: bool = True,
) -> DriveUnits:
    """The drive's units, from its objects, else from ``[axis.units]``.

    Parameters
    ----------
    read : callable
        ``read(index, sub)``: an object's value, or None (the drive lacks it or refused it).
    given : Mapping[str, float]
        The ``[axis.units]`` values (0 or absent: not given).
    where : str
        The axis, for messages.
    mode : int
        The mode whose factors are required (``require``); 0 (a status, which moves nothing):
        none, the ones nobody gives are NaN and the drive's own units stand.
    hint : str
        How the user gives a unit (``--units {key}=VALUE`` in ``rig drive``).
    has_position : bool
        The drive has a position 0x6064 (else only the position modes need its factor).

    Returns
    -------
    drivers.cia402_units.DriveUnits
        The factors and where each came from.
    """
    source: dict[str, str] = {}
    increments = _ratio(read, cia.POSITION_ENCODER_RESOLUTION)
    if increments:
        source["increments"] = "0x608F"
    elif given.get("counts_per_rev"):
        increments = float(given["counts_per_rev"])
        source["increments"] = "[axis.units] counts_per_rev"
    gear = _ratio(read, cia.GEAR_RATIO) or 1.0
    feed = _ratio(read, cia.FEED_CONSTANT)
    codes = _unit_codes(read, given, where, hint)
    position, velocity = _factors(read, (increments, gear, feed), codes, source)
    rated_torque = _rated(read, given, source, cia.RATED_TORQUE, "rated_torque")
    rated_current = _rated(read, given, source, cia.RATED_CURRENT, "rated_current")
    units = DriveUnits(position, velocity, rated_torque, rated_current, source)
    if mode:
        require(units, mode, where=where, hint=hint, has_position=has_position)
    return units


def _factors(
    read: Callable[[int, int], Any],
    ratios: tuple[float | None, float, float | None],
    codes: tuple[int, int],
    source: dict[str, str],
) -> tuple[float, float]:
    """The position's and the velocity's factors [units/rad, units/(rad/s)] from the ``ratios``
    (increments per revolution, gear 0x6091, feed 0x6092) and the unit ``codes``; NaN where they
    give none; where each came from in ``source``."""
    (increments, gear, feed), (pos_code, vel_code) = ratios, codes
    position = velocity = math.nan
    rotary = pos_code and SiUnit.decode(pos_code).unit != INCREMENTS
    if increments or rotary or feed:
        position = (
            position_per_revolution(increments or math.nan, gear=gear, feed=feed, unit=pos_code) / _TWO_PI
        )
        velocity = (
            velocity_per_revolution(
                increments or math.nan, gear=gear, feed=feed, unit=vel_code, position_unit=pos_code
            )
            / _TWO_PI
        )
        source["position"] = _code_source(read, pos_code, cia.SI_UNIT_POSITION, cia.POSITION_DIMENSION) or (
            "0x6092" if feed else source.get("increments", "")
        )
        source["velocity"] = (
            _code_source(read, vel_code, cia.SI_UNIT_VELOCITY, cia.VELOCITY_DIMENSION) or (source["position"])
        )
    elif vel_code and SiUnit.decode(vel_code).unit != INCREMENTS:  # rpm, rad/s: no increments needed
        velocity = velocity_per_revolution(math.nan, gear=gear, unit=vel_code) / _TWO_PI
        source["velocity"] = _code_source(read, vel_code, cia.SI_UNIT_VELOCITY, cia.VELOCITY_DIMENSION)
    return position, velocity


def _unit_codes(
    read: Callable[[int, int], Any], given: Mapping[str, float], where: str, hint: str
) -> tuple[int, int]:
    """The position's and the velocity's unit codes (0x60A8, 0x60A9; the older notation and
    dimension indices; else ``[axis.units]``; 0: none), each checked to be a unit."""
    pos_code = read(cia.SI_UNIT_POSITION, 0) or _dimension(read, where, hint, velocity=False)
    pos_code = pos_code or int(given.get("position_unit", 0))
    vel_code = read(cia.SI_UNIT_VELOCITY, 0) or _dimension(read, where, hint, velocity=True)
    vel_code = vel_code or int(given.get("velocity_unit", 0))
    for code, key in ((pos_code, "position_unit"), (vel_code, "velocity_unit")):
        if code:
            try:
                SiUnit.decode(code)
            except ValueError as exc:
                raise ConfigError(f"axis {where}: {exc}; set {hint.format(key=key)}") from None
    return pos_code, vel_code


def _rated(
    read: Callable[[int, int], Any], given: Mapping[str, float], source: dict[str, str], index: int, key: str
) -> float:
    """The rated torque [N m] (0x6076) or current [A] (0x6075) in mN m or mA, else ``given[key]``,
    else NaN; where it came from in ``source[key]``."""
    value = read(index, 0)
    source[key] = f"0x{index:04X}" if value else ("[axis.units]" if given.get(key) else "")
    return value / 1000.0 if value else float(given.get(key, 0.0)) or math.nan


def _dimension(read: Callable[[int, int], Any], where: str, hint: str, *, velocity: bool) -> int:
    """The 0x60A8/0x60A9 code of the drive's older notation and dimension indices (0: none)."""
    notation, dimension = (
        (cia.VELOCITY_NOTATION, cia.VELOCITY_DIMENSION)
        if velocity
        else (cia.POSITION_NOTATION, cia.POSITION_DIMENSION)
    )
    try:
        return dimension_unit(read(notation, 0), read(dimension, 0), velocity=velocity)
    except ValueError as exc:
        key = "velocity_unit" if velocity else "position_unit"
        raise ConfigError(f"axis {where}: {exc}; set {hint.format(key=key)}") from None


def _code_source(read: Callable[[int, int], Any], code: int, si_object: int, dimension: int) -> str:
    """Where a unit code came from: the SI unit object, the older dimension index, or "" (given)."""
    if not code:
        return ""
    if read(si_object, 0):
        return f"0x{si_object:04X}"
    if read(dimension, 0):
        return f"0x{dimension - 1:04X}/0x{dimension:04X}"
    return "[axis.units]"


#: modes whose command or feedback is a position: they need the position's factor
POSITION_MODES = frozenset({Mode.CSP, Mode.INTERPOLATED_POSITION, Mode.PROFILE_POSITION, Mode.HOMING})


def require(
    units: DriveUnits,
    mode: int,
    *,
    where: str,
    hint: str = "[axis.units] {key}",
    has_position: bool = True,
) -> None:
    """ConfigError naming the object and how to give it (``hint``) where ``mode`` needs a factor
    that ``units`` lacks: a mode's command its own; the position's every mode of a drive with a
    position 0x6064 (``has_position``), and the position modes always.

    Parameters
    ----------
    units : drivers.cia402_units.DriveUnits
        The factors found.
    mode : int
        The mode to run.
    where : str
        The axis, for messages.
    hint : str
        How the user gives a unit (``{key}`` replaced by its key).
    has_position : bool
        The drive has a position 0x6064.

    Raises
    ------
    ConfigError
        A factor the mode needs is missing, naming the object and how to give it.
    """
    need = NEEDS.get(Mode(mode)) if mode in {int(m) for m in Mode} else None
    if need is not None and need[0] == "velocity" and not math.isfinite(units.velocity):
        raise ConfigError(
            f"axis {where}: mode {Mode(mode).name} needs the drive's velocity unit (0x60A9, 0x608B/0x608C, "
            f"or increments per second by 0x608F), which it does not give; set "
            f"{hint.format(key='velocity_unit')} (0x00B44700: rpm) or {hint.format(key='counts_per_rev')} "
            "(increments per second)"
        )
    if need is not None and not math.isfinite(getattr(units, need[0])):
        raise ConfigError(
            f"axis {where}: mode {Mode(mode).name} needs 0x{need[1]:04X}, which the drive does not "
            f"give; set {hint.format(key=need[2])}"
        )
    if not math.isfinite(units.position) and (has_position or mode in POSITION_MODES):
        raise ConfigError(
            f"axis {where}: the drive gives no position resolution (0x608F, 0x60A8, 0x6092); "
            f"set {hint.format(key='counts_per_rev')}"
        )
