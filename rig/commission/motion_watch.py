"""What a commissioning move may do, checked at every look at the drive (``rig drive`` jog, move,
home): the measured motion against the motion asked for and the limits.

``MotionWatch.see`` takes each look's actual speed (0x606C) and position (0x6064, None on a drive
without one) in SI and raises ``SafetyStop`` naming what it saw, which ends the move in the
drive's own stop (``rig.commission.drive``):

- a shaft faster than the speed limit (``--limit`` of a jog; 1.5 times the drive's own profile
  velocity in a move or a homing, where it declares one), on two looks in a row;
- a jog turning the wrong way, or at more than 1.5 times the speed asked, on three looks in a
  row (a ramp's overshoot is smaller; a unit taken wrong is a factor, not a percentage);
- a move going the wrong way, or past its target by more than its tolerance (10 % of the travel,
  at least five position units), as a move by a multiple of the request does;
- position and speed that disagree: once the shaft has travelled a clear distance (0.2 rad and
  50 position units), the travel of 0x6064 must lie within a factor of two of what the speeds
  0x606C seen at the looks allow. Between two looks the shaft can have sped up and slowed down:
  it travels anything between the integrals of the envelopes an acceleration ``accel`` (the
  drive's profile and quick stop ramps, 0x6083-0x6085, its 0x60C5/0x60C6) leaves around the two
  speeds (``drivers.producer_watch.travel_band``); without an acceleration known the check is
  not made (looks far apart can miss a whole move: a 2 rad move at 20 rad/s between two looks
  at rest). A factor the host took wrong for one of them (a drive in tenths of a degree and rpm
  read as increments) shows as a ratio of 10-60; a lag between the two SDO reads of a look is a
  few percent.

Tolerances of one device unit are added everywhere, so a drive's coarse units cannot stop a move
that is right. Each check needs only the looks, never the wall clock: the same in lock-step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from drivers.errors import SafetyStop
from drivers.maps import cia
from drivers.producer_watch import declared_acceleration, travel_band

__all__ = ["MotionWatch", "watch_move"]

#: looks in a row a condition must hold before the stop: speed over the limit, the rest
_OVER_LIMIT_LOOKS, _WRONG_LOOKS = 2, 3
_MULTIPLE = 1.5  #: a jog faster than this many times the speed asked is not the jog asked for
_AGREE = 2.0  #: position travel and integrated speed within this factor of each other
_CLEAR_TRAVEL, _CLEAR_UNITS = 0.2, 50.0  #: [rad], [position units]: a travel the ratio is told on


@dataclass
class MotionWatch:
    """The looks at a move or a jog, each checked (see the module docstring)."""

    where: str  #: the drive and the move, for the message
    speed_limit: float = math.inf  #: [rad/s] (inf: none)
    asked_speed: float | None = None  #: [rad/s] of a jog
    start: float | None = None  #: [rad] of a move (None: the drive has no position)
    target: float | None = None  #: [rad] of a move
    speed_quantum: float = 0.0  #: [rad/s] one device unit of speed
    position_quantum: float = 0.0  #: [rad] one device unit of position
    units: str = ""  #: where the drive's factors came from, for the message
    accel: float = math.inf  #: [rad/s^2] the most the shaft speeds up or slows down (inf: not known)
    _over: int = 0  #: looks in a row over the speed limit
    _wrong: int = 0  #: looks in a row the wrong way
    _fast: int = 0  #: looks in a row far faster than asked
    _t: float | None = None  #: [s] the last look's time (None: none yet)
    _v: float = 0.0  #: [rad/s] its speed
    _integral: float = 0.0  #: [rad] the speed integrated over the looks
    _band: tuple[float, float] | None = (0.0, 0.0)  #: [rad] the least and most travel they allow
    speeds: list[tuple[float, float]] = field(default_factory=list)  #: (t [s], speed [rad/s])

    def see(self, t: float, speed: float, position: float | None) -> None:
        """One look at ``t`` [s]: ``speed`` [rad/s], ``position`` [rad] (None: none).

        Parameters
        ----------
        t : float
            [s].
        speed : float
            [rad/s].
        position : float | None
            [rad] (None: none).
        """
        if self._t is not None and t > self._t:
            dt = t - self._t
            self._integral += 0.5 * (speed + self._v) * dt
            step = travel_band(self._v, speed, dt, dt, resolution=(0.0, self.speed_quantum), accel=self.accel)
            band = self._band
            self._band = None if band is None or step is None else (band[0] + step[0], band[1] + step[1])
        self._t, self._v = t, speed
        self.speeds.append((t, speed))
        self._limit(speed)
        if self.asked_speed is not None:
            self._jog(speed)
        if position is not None and self.start is not None:
            if self.target is not None:
                self._move(position)
            self._agree(position - self.start)

    def _stop(self, text: str) -> SafetyStop:
        return SafetyStop(f"{self.where}: {text}")

    def _limit(self, speed: float) -> None:
        limit = self.speed_limit * 1.05 + self.speed_quantum
        self._over = self._over + 1 if abs(speed) > limit else 0
        if self._over >= _OVER_LIMIT_LOOKS:
            raise self._stop(
                f"the shaft turns at {speed:.4g} rad/s, faster than the limit {self.speed_limit:g} rad/s"
            )

    def _jog(self, speed: float) -> None:
        asked = float(self.asked_speed or 0.0)
        slack = 0.1 * abs(asked) + 2.0 * self.speed_quantum + 0.01
        wrong = asked != 0.0 and speed * math.copysign(1.0, asked) < -slack
        self._wrong = self._wrong + 1 if wrong else 0
        if self._wrong >= _WRONG_LOOKS:
            raise self._stop(f"the shaft turns the wrong way: {speed:.4g} rad/s, {asked:g} rad/s asked")
        fast = abs(speed) > _MULTIPLE * abs(asked) + slack
        self._fast = self._fast + 1 if fast else 0
        if self._fast >= _WRONG_LOOKS:
            raise self._stop(
                f"the shaft turns at {speed:.4g} rad/s, {abs(speed) / max(abs(asked), 1e-12):.3g} times the "
                f"{asked:g} rad/s asked{self._units_said}"
            )

    def _move(self, position: float) -> None:
        start, target = float(self.start or 0.0), float(self.target or 0.0)
        travel = target - start
        tol = max(0.1 * abs(travel), 5.0 * self.position_quantum, 1e-6)
        if travel and (position - start) * math.copysign(1.0, travel) < -tol:
            raise self._stop(
                f"moving away from the target: at {position:.6g} rad, from {start:.6g} to {target:g}"
            )
        if (position - target) * math.copysign(1.0, travel or 1.0) > tol:
            raise self._stop(
                f"past the target: at {position:.6g} rad, {abs(position - start):.4g} rad from the start "
                f"for a move of {abs(travel):.4g} rad{self._units_said}"
            )

    def _agree(self, travelled: float) -> None:
        integral, band = self._integral, self._band
        clear = max(_CLEAR_TRAVEL, _CLEAR_UNITS * self.position_quantum)
        if band is None or max(abs(travelled), abs(integral)) < clear:
            return
        least, most = band
        slack = 2.0 * self.position_quantum
        over = most * (_AGREE if most > 0.0 else 1.0 / _AGREE) + slack
        under = least * (_AGREE if least < 0.0 else 1.0 / _AGREE) - slack
        if not under <= travelled <= over:
            raise self._stop(
                f"the position 0x6064 moved {travelled:.4g} rad while the speed 0x606C integrates to "
                f"{integral:.4g} rad ({least:.4g} to {most:.4g} rad at most {self.accel:.4g} rad/s^2 between "
                f"the looks): the drive's units are not those drive-rig took{self._units_said}"
            )

    @property
    def _units_said(self) -> str:
        return (
            f" (units from {self.units}; check them with rig drive status, or give --eds)"
            if self.units
            else ""
        )

    def reached(self) -> float:
        """[rad/s] the mean measured speed over the second half of the looks (NaN: none).

        Returns
        -------
        float
            [rad/s].
        """
        if not self.speeds:
            return math.nan
        half = self.speeds[len(self.speeds) // 2 :]
        return sum(v for _t, v in half) / len(half)


def watch_move(tool: Any, **kw: Any) -> MotionWatch:
    """A watch of the move about to start by ``tool`` (a ``DriveTool``; ``what``: the move in
    words, the rest ``MotionWatch``'s), with the drive's quanta, units and ramps (0x6083-0x6085:
    the most a profile move's shaft speeds up or slows down), and its first look (a look after the
    move began would miss its start).

    Parameters
    ----------
    tool : Any
        A ``DriveTool``.
    **kw : Any
        ``what`` (the move in words) and ``MotionWatch``'s fields.

    Returns
    -------
    MotionWatch
        The watch, its first look taken.
    """
    a = tool.axis
    position_quantum, speed_quantum = a.quanta()
    source = a.units.source
    units = ", ".join(f"{k} {source[k]}" for k in ("position", "velocity") if source.get(k))
    ramps = [a.discovery.optional(index) for index in (cia.PROFILE_ACCELERATION, cia.PROFILE_DECELERATION)]
    accel = declared_acceleration(
        [*ramps, a.discovery.optional(cia.QUICK_STOP_DECELERATION)], a.units.velocity
    )
    where = f"{a.where}: {kw.pop('what')}"
    watch = MotionWatch(where, speed_quantum=speed_quantum, position_quantum=position_quantum, **kw)
    watch.units, watch.accel = units, accel
    position, speed = tool.actual()
    watch.see(tool.elapsed(), speed, position)
    return watch
