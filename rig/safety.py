"""Safety checks of the host loop: every violation becomes one ``SafetyStop`` with its reason.

``Limits.check`` runs every cycle on the measured feedback and on the command
about to be sent; the host loop turns any ``SafetyStop``, device fault, lost
TPDO or heartbeat, NaN, controller exception or Ctrl-C into the one safe-stop
path (``rig.loop.HostLoop.safe_stop``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from drivers.errors import SafetyStop
from rig.config import LimitsConfig

__all__ = ["Limits"]


@dataclass
class Limits:
    """The configured limits, with the watchdog state."""

    cfg: LimitsConfig
    period: float
    _stale: int = 0
    _last_stamp: float | None = None
    _last_position: float | None = None

    def check_feedback(self, position: float, velocity: float, current: float) -> None:
        c = self.cfg
        for name, value in (("position", position), ("speed", velocity), ("current", current)):
            if not math.isfinite(value):
                raise SafetyStop(f"{name} feedback is {value!r}")
        if abs(velocity) > c.speed:
            raise SafetyStop(f"speed {velocity:.4g} rad/s exceeds the limit {c.speed:g} rad/s")
        # a jump no motor can make within the speed limit: an encoder glitch or a lost count
        max_step = (c.speed if math.isfinite(c.speed) else 1000.0) * self.period * 3.0
        if self._last_position is not None and abs(position - self._last_position) > max_step:
            jump = position - self._last_position
            raise SafetyStop(
                f"position jumped by {jump:.4g} rad in one period (> {max_step:.3g} rad): encoder glitch?"
            )
        self._last_position = position
        if not c.position_min <= position <= c.position_max:
            raise SafetyStop(
                f"position {position:.4g} rad outside [{c.position_min:g}, {c.position_max:g}] rad"
            )
        if abs(current) > c.current:
            raise SafetyStop(f"current {current:.4g} A exceeds the limit {c.current:g} A")

    def check_command(self, command: float) -> None:
        if not math.isfinite(command):
            raise SafetyStop(f"controller output is {command!r}")
        if abs(command) > self.cfg.command:
            raise SafetyStop(f"command {command:.4g} exceeds the limit {self.cfg.command:g}")

    def watchdog(self, tpdo_stamp: float | None) -> None:
        """Count cycles without a new TPDO; stop after ``watchdog_periods``."""
        if tpdo_stamp is not None and tpdo_stamp != self._last_stamp:
            self._last_stamp = tpdo_stamp
            self._stale = 0
            return
        self._stale += 1
        if self._stale >= self.cfg.watchdog_periods:
            raise SafetyStop(f"no TPDO for {self._stale} periods ({self._stale * self.period * 1e3:.3g} ms)")

    def heartbeat(self, last: float | None, now: float) -> None:
        timeout = self.cfg.heartbeat_timeout
        if timeout > 0.0 and last is not None and now - last > timeout:
            raise SafetyStop(f"heartbeat lost: none for {now - last:.3g} s (timeout {timeout:g} s)")
