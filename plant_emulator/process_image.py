"""The process data of an emulated CiA 402 drive: set-points in, feedback out, in its own units.

A drive's units are whatever its objects say (``drivers.maps.units``): increments
per revolution from 0x608F (or the profile), gear 0x6091, feed 0x6092, SI unit
codes 0x60A8/0x60A9 (or the profile); torque and current in per mille of its
ratings 0x6076/0x6075 (mN m, mA; or the physics' ratings where the drive lacks
them). ``ProcessImage`` converts the targets to SI for the physics and latches
the physics' state into the feedback objects the drive has; an object the EDS
lacks is neither read nor written.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.maps.units import position_per_revolution, velocity_per_revolution
from drivers.producer_watch import ACCELERATION_LIMITS
from plant_emulator.axes import Axis
from plant_emulator.device_profile import Units
from plant_emulator.od_store import ObjectStore

__all__ = ["UNIT_OBJECTS", "DriveUnits", "ProcessImage", "Ratings"]

#: objects whose write changes the drive's units or ratings (``ProcessImage.refresh``)
UNIT_OBJECTS = frozenset(
    {
        cia.POSITION_ENCODER_RESOLUTION,
        cia.GEAR_RATIO,
        cia.FEED_CONSTANT,
        cia.SI_UNIT_POSITION,
        cia.SI_UNIT_VELOCITY,
    }
    | {cia.RATED_TORQUE, cia.RATED_CURRENT, cia.MAX_CURRENT, cia.MAX_MOTOR_SPEED}
)
_VOLTAGE, _DQ_VOLTAGE, _CST, _CSV, _PV, _CSP = (
    int(m) for m in (Mode.VOLTAGE, Mode.DQ_VOLTAGE, Mode.CST, Mode.CSV, Mode.PROFILE_VELOCITY, Mode.CSP)
)
_TWO_PI = 2.0 * math.pi
_I32_MIN, _I32_MAX = -(2**31), 2**31 - 1
_I16_MIN, _I16_MAX = -(2**15), 2**15 - 1
_POSITION_ACTUAL, _VELOCITY_ACTUAL = cia.POSITION_ACTUAL, cia.VELOCITY_ACTUAL
_TORQUE_ACTUAL, _CURRENT_ACTUAL, _FOLLOWING = (
    cia.TORQUE_ACTUAL,
    cia.CURRENT_ACTUAL,
    cia.FOLLOWING_ERROR_ACTUAL,
)


@dataclass(frozen=True)
class Ratings:
    """A drive's rated and maximum values, SI (also written to its objects where it has them)."""

    rated_current: float  #: 0x6075 [A]
    rated_torque: float  #: 0x6076 [N m]
    max_current_permille: int  #: 0x6073 [per mille of the rated current]
    max_speed_rpm: int  #: 0x6080 [rpm]
    #: [rad/s^2] the most the motor can speed up or slow down (0x60C5/0x60C6; inf: not said)
    max_acceleration: float = math.inf

    def as_stored(self) -> Ratings:
        """These ratings as the object dictionary holds them (whole mA and mN m).

        Returns
        -------
        Ratings
            The ratings rounded to whole mA and mN m.
        """
        return replace(
            self,
            rated_current=round(self.rated_current * 1000) / 1000,
            rated_torque=round(self.rated_torque * 1000) / 1000,
        )


@dataclass(frozen=True)
class DriveUnits:
    """Device units per SI unit: ``position`` per rad, ``velocity`` per rad/s, ``acceleration``
    per rad/s^2 (velocity units per second); ``increments`` per rad of the encoder."""

    increments: float  #: encoder increments per rad
    position: float  #: position units per rad
    velocity: float  #: velocity units per rad/s
    acceleration: float  #: acceleration units per rad/s^2


def _ratio(read: Callable[[int, int], Any], index: int) -> float:
    return float(read(index, 1)) / float(read(index, 2) or 1)


def drive_units(od: ObjectStore, has: Callable[[int], bool], given: Units) -> DriveUnits:
    """The units of a drive from its objects, or from its profile where it lacks them."""
    read = od.read
    res = cia.POSITION_ENCODER_RESOLUTION
    increments = _ratio(read, res) if has(res) else float(given.counts_per_rev)
    gear = _ratio(read, cia.GEAR_RATIO) if has(cia.GEAR_RATIO) else 1.0
    feed = _ratio(read, cia.FEED_CONSTANT) if has(cia.FEED_CONSTANT) else None
    pos_code = read(cia.SI_UNIT_POSITION, 0) if has(cia.SI_UNIT_POSITION) else given.position
    vel_code = read(cia.SI_UNIT_VELOCITY, 0) if has(cia.SI_UNIT_VELOCITY) else given.velocity
    position = position_per_revolution(increments, gear=gear, feed=feed, unit=pos_code) / _TWO_PI
    velocity = (
        velocity_per_revolution(increments, gear=gear, feed=feed, unit=vel_code, position_unit=pos_code)
        / _TWO_PI
    )
    return DriveUnits(increments / _TWO_PI, position, velocity, velocity)


def _clamp(value: int, bits: int) -> int:
    high = (1 << (bits - 1)) - 1
    return max(-high - 1, min(high, value))


class ProcessImage:
    """A drive's set-point and feedback objects; see the module docstring.

    Parameters
    ----------
    od : ObjectStore
        The drive's object store.
    has : Callable[[int], bool]
        Whether the drive has an object (index).
    given : Units
        The profile's ``[units]`` (where the EDS lacks them).
    ratings : Ratings
        The motor's ratings.
    dq : bool, optional
        A dq-voltage drive (its targets complex).
    """

    def __init__(
        self, od: ObjectStore, has: Callable[[int], bool], given: Units, ratings: Ratings, *, dq: bool = False
    ) -> None:
        """``dq``: the axis has dq currents and a frame angle (the grid converter)."""
        self.od = od
        self.has = has
        self.given = given
        self.ratings = ratings
        self.home_shift = 0  #: [position units] added to positions by homing (0x607C)
        self._inputs = has(cia.DIGITAL_INPUTS)
        self._torque = has(cia.TORQUE_ACTUAL)
        self._current = has(cia.CURRENT_ACTUAL)
        self._following = has(cia.FOLLOWING_ERROR_ACTUAL)
        self._demand = has(cia.POSITION_DEMAND)
        self._dq = dq and has(cia.DQ_CURRENT) and has(cia.FRAME_ANGLE) and has(cia.FRAME_SPEED)
        self.refresh()

    def refresh(self) -> None:
        """The unit or rating objects changed (an SDO write, an NMT reset, ``rate``): the values
        every period uses are taken again."""
        self.units = drive_units(self.od, self.has, self.given)
        self.rated_torque = self._object(cia.RATED_TORQUE, self.ratings.rated_torque, 1e-3)
        self.rated_current = self._object(cia.RATED_CURRENT, self.ratings.rated_current, 1e-3)
        permille = self._object(cia.MAX_CURRENT, float(self.ratings.max_current_permille))
        self.max_current = permille / 1000.0 * self.rated_current
        self.max_speed = self._object(cia.MAX_MOTOR_SPEED, float(self.ratings.max_speed_rpm)) * _TWO_PI / 60.0
        accel = self.ratings.max_acceleration * self.units.velocity  # in velocity units per s
        for index in ACCELERATION_LIMITS:  # read-only: the motor's
            if self.has(index):
                self.od.write(index, 0, min(math.ceil(accel), 0xFFFF_FFFE) if math.isfinite(accel) else 0)

    # --- ratings: the objects where the drive has them, else the physics' values ---------------
    def _object(self, index: int, default: float, scale: float = 1.0) -> float:
        return float(self.od.read(index, 0)) * scale if self.has(index) else default

    #: rated_torque [N m] (0x6076 is mN m), rated_current [A] (0x6075 mA), max_current [A]
    #: (0x6073 per mille of the rated current), max_speed [rad/s] (0x6080 rpm): set by ``refresh``
    rated_torque: float
    rated_current: float
    max_current: float
    max_speed: float

    def rate(self, ratings: Ratings, counts_per_rev: int | None) -> None:
        """Take ``ratings`` and write them, and the resolution (None: the drive's own), into the
        objects the drive has.

        Parameters
        ----------
        ratings : Ratings
            The motor's ratings.
        counts_per_rev : int | None
            [increments/rev] (None: the drive's own).
        """
        self.ratings = ratings
        write = self.od.write
        for index, value in (
            (cia.RATED_CURRENT, round(ratings.rated_current * 1000)),  # mA
            (cia.RATED_TORQUE, round(ratings.rated_torque * 1000)),  # mN m
            (cia.MAX_CURRENT, ratings.max_current_permille),
            (cia.MAX_MOTOR_SPEED, ratings.max_speed_rpm),
        ):
            if self.has(index):
                write(index, 0, value)
        if counts_per_rev is not None and self.has(cia.POSITION_ENCODER_RESOLUTION):
            write(cia.POSITION_ENCODER_RESOLUTION, 1, counts_per_rev)
            write(cia.POSITION_ENCODER_RESOLUTION, 2, 1)
        self.refresh()

    # --- set-points -----------------------------------------------------------------------------
    def target(self, mode: int) -> complex:
        """The present target of ``mode`` in SI (V, N m, rad/s, rad).

        Parameters
        ----------
        mode : int
            The mode of operation.

        Returns
        -------
        complex
            Its target in SI (V, N m, rad/s, rad; a dq voltage complex).
        """
        read, u = self.od.read, self.units
        if mode == _VOLTAGE:
            return complex(read(cia.TARGET_VOLTAGE, 0) / 1000.0)  # mV -> V
        if mode == _DQ_VOLTAGE:
            return complex(read(cia.DQ_VOLTAGE, 1), read(cia.DQ_VOLTAGE, 2)) / 1000.0
        if mode == _CST:
            return complex(read(cia.TARGET_TORQUE, 0) / 1000.0 * self.rated_torque)
        if mode in (_CSV, _PV):
            return complex(read(cia.TARGET_VELOCITY, 0) / u.velocity)
        if mode == _CSP:
            return complex((read(cia.TARGET_POSITION, 0) - self.home_shift) / u.position)
        return 0j

    def acceleration(self, index: int, default: float) -> float:
        """An acceleration object (0x6083-0x6085) in rad/s^2, or ``default`` where the drive lacks it.

        Parameters
        ----------
        index : int
            0x6083, 0x6084 or 0x6085.
        default : float
            [rad/s^2] where the drive lacks it.

        Returns
        -------
        float
            [rad/s^2].
        """
        return float(self.od.read(index, 0)) / self.units.acceleration if self.has(index) else default

    # --- feedback -------------------------------------------------------------------------------
    def latch(
        self, axis: Axis, *, demand: float | None, inputs: int = 0, offset: int = 0, ahead: float = 0.0
    ) -> int:
        """Write the axis's state into the feedback objects; the latched position [position units]
        (``offset`` added: fault injection). ``demand``: the position set-point [rad] of a
        position mode (for 0x60F4), else None; ``inputs``: 0x60FD; ``ahead`` [s]: the sample's
        time after the axis's (real time: a SYNC between period boundaries; the angle moves on
        at the axis's speed).

        Parameters
        ----------
        axis : Axis
            The physics behind the drive.
        demand : float | None
            [rad] the position set-point of a position mode (0x60F4), else None.
        inputs : int, optional
            0x60FD, the digital inputs.
        offset : int, optional
            [position units] added to the position (fault injection).
        ahead : float, optional
            [s] the sample's time after the axis's.

        Returns
        -------
        int
            [position units] the latched position.
        """
        write, u = self.od.write, self.units
        angle = axis.position + axis.velocity * ahead if ahead else axis.position
        pos = math.floor(angle * u.position) + self.home_shift + offset
        pos = _I32_MIN if pos < _I32_MIN else _I32_MAX if pos > _I32_MAX else pos
        write(_POSITION_ACTUAL, 0, pos)
        value = round(axis.velocity * u.velocity)  # each clamped to its object's range, inline
        write(_VELOCITY_ACTUAL, 0, _I32_MIN if value < _I32_MIN else _I32_MAX if value > _I32_MAX else value)
        if self._torque:
            value = round(axis.torque / self.rated_torque * 1000.0)
            value = _I16_MIN if value < _I16_MIN else _I16_MAX if value > _I16_MAX else value
            write(_TORQUE_ACTUAL, 0, value)
        if self._current:
            value = round(axis.current / self.rated_current * 1000.0)
            value = _I16_MIN if value < _I16_MIN else _I16_MAX if value > _I16_MAX else value
            write(_CURRENT_ACTUAL, 0, value)
        if self._demand and demand is not None:
            write(cia.POSITION_DEMAND, 0, _clamp(round(demand * u.position) + self.home_shift, 32))
        if self._following and demand is not None:
            write(_FOLLOWING, 0, _clamp(round(demand * u.position) + self.home_shift - pos, 32))
        if self._inputs:
            write(cia.DIGITAL_INPUTS, 0, inputs)
        if self._dq:
            i_dq = axis.i_dq  # type: ignore[attr-defined]
            write(cia.DQ_CURRENT, 1, round(i_dq.real * 1000.0))  # mA
            write(cia.DQ_CURRENT, 2, round(i_dq.imag * 1000.0))
            write(cia.FRAME_ANGLE, 0, round(angle * 1e6))  # urad
            write(cia.FRAME_SPEED, 0, round(axis.velocity * 1000.0))  # mrad/s
        return pos
