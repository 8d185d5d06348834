"""A speed-commanded axis's measured speed against its command, every cycle of a run.

In the modes whose command is a speed (CiA 402 csv and pv, a Modbus inverter's speed), the drive's
own loop makes the shaft follow the command; a shaft that turns the other way, or at more than
twice the command, and does not come towards it, is a drive whose units, direction (polarity
0x607E, a swapped motor phase) or loop are not what the host took. ``FollowCheck.see`` raises
``SafetyStop`` naming both speeds once that has held for the whole of its window (at least five
periods and 50 ms), never on a transient: a step or a reversal of the command, which the drive
follows along its own ramp, comes towards the command, and the check holds its fire while it
does (the mean of the window's second half closer to the command than its first half's).
The tolerance is a fifth of the command plus two speed units of the axis plus a twentieth of
the axis's speed limit, so a drive's coarse speed unit and its ripple never stop a run.
"""

from __future__ import annotations

import collections
import math

from drivers.errors import SafetyStop

__all__ = ["SPEED_MODES", "FollowCheck"]

SPEED_MODES = frozenset({"csv", "pv", "speed"})  #: modes whose command is a speed [rad/s]
_MULTIPLE = 2.0  #: faster than this many times the command is no following
_WINDOW = 0.05  #: [s] at least, and five periods at least


class FollowCheck:
    """A speed-commanded axis's speed against its command (module docstring).

    Parameters
    ----------
    who : str
        The axis, as the stop names it.
    period : float
        The loop's period [s].
    speed_limit : float
        The axis's speed limit [rad/s] (inf: none).
    quantum : float
        One speed unit of the axis [rad/s].
    """

    def __init__(self, who: str, period: float, speed_limit: float, quantum: float) -> None:
        self.who = who
        self.window = max(5, math.ceil(_WINDOW / period - 1e-9))
        self.slack = 2.0 * quantum + (0.05 * speed_limit if math.isfinite(speed_limit) else 0.0)
        self.speeds: collections.deque[float] = collections.deque(maxlen=self.window)
        self.command: float | None = None  #: [rad/s] the last command sent

    def sent(self, command: float) -> None:
        """The command of this cycle (the next samples answer it).

        Parameters
        ----------
        command : float
            [rad/s] the speed commanded.
        """
        self.command = command

    def see(self, speed: float) -> None:
        """A new sample's speed.

        Parameters
        ----------
        speed : float
            [rad/s] the measured speed.

        Raises
        ------
        SafetyStop
            Naming both speeds, once the shaft has turned the other way or too fast for the whole
            window without coming towards the command.
        """
        cmd = self.command
        if cmd is None or not math.isfinite(speed):
            return
        tol = 0.2 * abs(cmd) + self.slack
        wrong = cmd != 0.0 and speed * math.copysign(1.0, cmd) < -tol
        fast = abs(speed) > _MULTIPLE * abs(cmd) + tol
        if not (wrong or fast):
            self.speeds.clear()
            return
        self.speeds.append(speed)
        if len(self.speeds) < self.window:
            return
        half = self.window // 2
        early = sum(list(self.speeds)[:half]) / half
        late = sum(list(self.speeds)[-half:]) / half
        if abs(late - cmd) < abs(early - cmd):
            return  # coming towards the command: a transient along the drive's ramp
        said = (
            "turns the other way" if wrong else f"turns at {abs(speed) / max(abs(cmd), 1e-12):.3g} times it"
        )
        raise SafetyStop(
            f"{self.who}: the shaft {said}: {speed:.4g} rad/s for {self.window} periods against a command "
            f"of {cmd:.4g} rad/s, not coming towards it (the drive's units, polarity 0x607E or loop are "
            "not what the host took)"
        )
