"""Per-axis safety checks of the host loop: every violation becomes one ``SafetyStop`` naming the axis.

``AxisGuard.check_feedback`` runs every cycle on an axis's sample (the watchdog on
its ``stamp``, NaN in a measured quantity, speed, a position jump no motor can
make, the position window, current); ``check_command`` on the command about to
be sent. The host loop turns any ``SafetyStop`` into the one safe-stop path.
"""

from __future__ import annotations

import math

from drivers.base import AxisDriver, Feedback
from drivers.errors import SafetyStop
from rig.config import AxisLimits

__all__ = ["AxisGuard"]


class AxisGuard:
    """The configured limits of one axis, with its watchdog state; ``period`` [s] is the loop's."""

    def __init__(self, axis: AxisDriver, limits: AxisLimits, period: float) -> None:
        self.axis = axis
        self.limits = limits
        self.period = period
        self.who = f"{axis.name}, {axis.where}"
        self.measures = axis.measures
        self.sample_name = getattr(axis, "sample_name", "sample")
        self._stale = 0
        self._last_stamp: float | None = None
        self._last_position: float | None = None
        speed = limits.speed if math.isfinite(limits.speed) else 1000.0
        #: a position step no motor makes within the speed limit: an encoder glitch or a lost count
        self.max_step = speed * period * 3.0

    def _stop(self, text: str) -> SafetyStop:
        return SafetyStop(f"{self.who}: {text}")

    def check_feedback(self, fb: Feedback) -> None:
        c = self.limits
        self._watchdog(fb.stamp)
        for name in self.measures:
            value = getattr(fb, name)
            if not math.isfinite(value):
                raise self._stop(f"{name} feedback is {value!r}")
        if abs(fb.velocity) > c.speed:
            raise self._stop(f"speed {fb.velocity:.4g} rad/s exceeds the limit {c.speed:g} rad/s")
        if "position" in self.measures:
            self._check_position(fb.position)
        if abs(fb.current) > c.current:
            raise self._stop(f"current {fb.current:.4g} A exceeds the limit {c.current:g} A")

    def _check_position(self, position: float) -> None:
        c = self.limits
        last = self._last_position
        if last is not None and abs(position - last) > self.max_step:
            raise self._stop(
                f"position jumped by {position - last:.4g} rad in one period "
                f"(> {self.max_step:.3g} rad): encoder glitch?"
            )
        self._last_position = position
        if not c.position_min <= position <= c.position_max:
            raise self._stop(
                f"position {position:.4g} rad outside [{c.position_min:g}, {c.position_max:g}] rad"
            )

    def check_command(self, command: float | complex) -> None:
        size = abs(command)
        if not math.isfinite(size):
            raise SafetyStop(f"controller output is {command!r}")
        if size > self.limits.command:
            raise self._stop(f"command {size:.4g} exceeds the limit {self.limits.command:g}")

    def _watchdog(self, stamp: float | None) -> None:
        """Count cycles without a new sample; stop after ``watchdog_periods``."""
        if stamp is not None and stamp != self._last_stamp:
            self._last_stamp = stamp
            self._stale = 0
            return
        self._stale += 1
        if self._stale >= self.limits.watchdog_periods:
            raise self._stop(
                f"no {self.sample_name} for {self._stale} periods ({self._stale * self.period * 1e3:.3g} ms)"
            )
