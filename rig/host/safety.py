"""Per-axis safety checks of the host loop: every violation becomes one ``SafetyStop`` naming the axis.

``AxisGuard.check_feedback`` runs every cycle on an axis's sample (the watchdog on
its ``stamp``, counted in periods of the loop's cycle index, so a real-time cycle that
waited several periods counts as all of them, NaN in a measured quantity, speed, a position jump no motor can
make, a position that contradicts the axis's own speed (``AxisDriver.foreign_sample``: another
producer's frame), the position window, current, and in a speed mode the speed against the
command: ``rig.host.motion_check``); ``check_command`` on the command about to
be sent: its size, or, for a position command (CSP), its travel from where the axis
stood at the first sample, the position window, and its step from the last command (the
first from the measured position), which no motor within the speed limit makes in the
periods between them (counted, as the feedback's, in the loop's cycle index: a real-time
cycle after a late one commands the reference of its own time, several periods on). The
host loop turns any ``SafetyStop`` into the one safe-stop path.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from drivers.base import POSITION_COMMANDS, AxisDriver, Feedback, feedback_fields
from drivers.errors import SafetyStop
from drivers.producer_watch import OtherProducer
from rig.config import AxisLimits
from rig.host.motion_check import SPEED_MODES, FollowCheck

__all__ = ["AxisGuard"]


class AxisGuard:
    """The configured limits of one axis, with its watchdog state.

    Parameters
    ----------
    axis : AxisDriver
        The axis guarded.
    limits : AxisLimits
        Its ``[axis.limits]``.
    period : float
        [s] the loop's period.
    realtime : bool
        A real-time run: the watchdog waits at least ``limits.watchdog`` [s].
    """

    def __init__(
        self, axis: AxisDriver, limits: AxisLimits, period: float, *, realtime: bool = False
    ) -> None:
        self.axis = axis
        self.limits = limits
        self.period = period
        #: periods without a new sample before the stop: in real time, at least ``limits.watchdog`` [s]
        self.watchdog_periods = limits.watchdog_periods
        if realtime:
            self.watchdog_periods = max(self.watchdog_periods, math.ceil(limits.watchdog / period - 1e-9))
        self.who = f"{axis.name}, {axis.where}"
        self.measures = axis.measures
        #: (the measures it was made for, their names, their values of a sample), made on first use
        self._measured: tuple[object, tuple[str, ...], Callable[[Feedback], tuple[float, ...]]] = (
            None,
            (),
            feedback_fields(()),
        )
        self.sample_name = getattr(axis, "sample_name", "sample")
        self._stale = 0
        self._fresh_k = -1  #: the cycle index of the last new sample (-1: none yet)
        self._last_stamp: float | None = None
        self._last_position: float | None = None
        self._last_sample: Feedback | None = None  #: the sample of ``_last_position``
        self._position_k = 0  #: the cycle index of ``_last_position``
        self.position_command = getattr(axis, "mode", None) in POSITION_COMMANDS
        self.origin: float | None = None  #: [rad] the first measured position
        self._last_command: float | None = None  #: [rad] the last position command
        self._command_k = 0  #: the cycle index of ``_last_command``
        #: a speed-commanded axis's speed against its command (``rig.host.motion_check``)
        self.follow = (
            FollowCheck(self.who, period, limits.speed, axis.quanta()[1])
            if getattr(axis, "mode", None) in SPEED_MODES
            else None
        )
        speed = limits.speed if math.isfinite(limits.speed) else 1000.0
        #: a position step no motor makes within the speed limit: an encoder glitch or a lost count
        self.max_step = speed * period * 3.0

    def _stop(self, text: str) -> SafetyStop:
        return SafetyStop(f"{self.who}: {text}")

    def check_feedback(self, fb: Feedback, k: int, sample_k: int | None = None) -> None:
        """Check the sample of cycle ``k``.

        Parameters
        ----------
        fb : Feedback
            The axis's sample.
        k : int
            The loop's cycle index, missed cycles included.
        sample_k : int | None
            The cycle whose SYNC the sample was taken at (None: ``k``); the position step is bounded by
            the periods between the samples' SYNCs.

        Raises
        ------
        SafetyStop
            Naming the axis and the limit: watchdog, NaN, speed, position jump or window, current,
            the speed against the command (``OtherProducer``: a sample the axis's own speed
            contradicts).
        """
        c = self.limits
        fresh = self._watchdog(fb.stamp, k)
        if self.measures is not self._measured[0]:  # (set once the axis knows what it measures)
            self._measured = (self.measures, tuple(self.measures), feedback_fields(self.measures))
        _, names, measured = self._measured
        values = measured(fb)
        if not all(map(math.isfinite, values)):
            for name, value in zip(names, values):
                if not math.isfinite(value):
                    raise self._stop(f"{name} feedback is {value!r}")
        if abs(fb.velocity) > c.speed:
            raise self._stop(f"speed {fb.velocity:.4g} rad/s exceeds the limit {c.speed:g} rad/s")
        if self.follow is not None and fresh:
            self.follow.see(fb.velocity)
        if "position" in self.measures and fresh:  # a repeated sample is no step (nor its time)
            self._check_position(fb.position, k if sample_k is None else sample_k, fb)
        if abs(fb.current) > c.current:
            raise self._stop(f"current {fb.current:.4g} A exceeds the limit {c.current:g} A")

    def _check_position(self, position: float, k: int, fb: Feedback | None = None) -> None:
        c = self.limits
        last = self._last_position
        if last is not None:
            periods = k - self._position_k
            if abs(position - last) > self.max_step * periods:
                raise self._stop(
                    f"position jumped by {position - last:.4g} rad in {periods} period(s) "
                    f"(> {self.max_step * periods:.3g} rad): encoder glitch?"
                )
            before = self._last_sample
            if periods == 1 and before is not None and fb is not None:
                said = self.axis.foreign_sample(before, fb)
                if said is not None:
                    raise OtherProducer(said)
        self._last_position, self._position_k, self._last_sample = position, k, fb
        if self.origin is None:
            self.origin = position
        if not c.position_min <= position <= c.position_max:
            raise self._stop(
                f"position {position:.4g} rad outside [{c.position_min:g}, {c.position_max:g}] rad"
            )

    def check_command(self, command: float | complex, k: int) -> None:
        """Check the command of cycle ``k`` before it is sent.

        Parameters
        ----------
        command : float | complex
            The command, in the axis's mode's unit.
        k : int
            The loop's cycle index, missed cycles included.

        Raises
        ------
        SafetyStop
            Naming the axis: not finite, over the limit, or a position command's travel, window or
            step.
        """
        size = abs(command)
        if not math.isfinite(size):
            raise SafetyStop(f"controller output is {command!r}")
        if self.position_command:
            self._check_position_command(float(command), k)  # type: ignore[arg-type]
        elif size > self.limits.command:
            raise self._stop(f"command {size:.4g} exceeds the limit {self.limits.command:g}")
        if self.follow is not None:
            self.follow.sent(float(command))  # type: ignore[arg-type]

    def _check_position_command(self, x: float, k: int) -> None:
        c = self.limits
        origin = self.origin if self.origin is not None else 0.0
        if abs(x - origin) > c.command:
            raise self._stop(
                f"position command {x:.6g} rad is {x - origin:.4g} rad from the start ({origin:.6g} rad), "
                f"beyond the limit {c.command:g} rad"
            )
        if not c.position_min <= x <= c.position_max:
            raise self._stop(
                f"position command {x:.6g} rad outside [{c.position_min:g}, {c.position_max:g}] rad"
            )
        commanded = self._last_command is not None
        last = self._last_command if commanded else self._last_position
        periods = max(1, k - (self._command_k if commanded else self._position_k))
        if last is not None and abs(x - last) > self.max_step * periods:
            what = "the last command" if commanded else "the measured position"
            raise self._stop(
                f"position command {x:.6g} rad steps {x - last:.4g} rad from {what} in {periods} "
                f"period(s) (> {self.max_step:.3g} rad a period at the speed limit)"
            )
        self._last_command, self._command_k = x, k

    def _watchdog(self, stamp: float | None, k: int) -> bool:
        """Count the periods since the last new sample; stop after ``self.watchdog_periods``.
        True when the sample is new."""
        if stamp is not None and stamp != self._last_stamp:
            self._last_stamp = stamp
            self._fresh_k = k
            self._stale = 0
            return True
        self._stale = k - self._fresh_k
        if self._stale >= self.watchdog_periods:
            raise self._stop(
                f"no {self.sample_name} for {self._stale} periods ({self._stale * self.period * 1e3:.3g} ms)"
            )
        return False
