"""Set-point generators of a drive's profile modes, pure functions of time (SI, one step of h [s]).

- ``SpeedRamp``: a speed [rad/s] moving toward its target at ``accel`` [rad/s^2] away from
  zero and ``decel`` toward it (profile velocity, 0x6083/0x6084; halt; homing).
- ``PositionProfile``: a point-to-point move [rad] limited in speed, acceleration and
  deceleration (profile position, 0x6081/0x6083/0x6084): each step the speed toward the
  target rises by at most ``accel h``, never exceeds ``v_max``, and never exceeds
  sqrt(2 decel |e|), the speed from which ``decel`` stops at the target; the last step lands
  on it. Near the end the discrete braking may exceed ``decel`` by up to one step's worth
  (the price of landing exactly).
"""

from __future__ import annotations

import math

__all__ = ["PositionProfile", "SpeedRamp"]


class SpeedRamp:
    """See the module docstring; ``value`` is the present set-point [rad/s].

    Parameters
    ----------
    value : float, optional
        [rad/s] the present set-point.
    """

    __slots__ = ("value",)

    def __init__(self, value: float = 0.0) -> None:
        self.value = value

    def step(self, target: float, accel: float, decel: float, h: float) -> float:
        """Advance ``h`` [s] toward ``target``, accelerating by ``accel`` and decelerating by ``decel``.

        Parameters
        ----------
        target : float
            [rad/s].
        accel, decel : float
            [rad/s^2] > 0.
        h : float
            [s].

        Returns
        -------
        float
            [rad/s] the new set-point.
        """
        v = self.value
        if v == target:
            return v
        speeding_up = v * target >= 0.0 and abs(target) > abs(v)
        dv = (accel if speeding_up else decel) * h
        v = target if abs(target - v) <= dv else v + math.copysign(dv, target - v)
        self.value = v
        return v


class PositionProfile:
    """See the module docstring; ``position`` [rad] and ``velocity`` [rad/s] are the set-point.

    Parameters
    ----------
    position : float, optional
        [rad] the set-point.
    velocity : float, optional
        [rad/s] its speed.
    """

    __slots__ = ("position", "target", "velocity")

    def __init__(self, position: float = 0.0, velocity: float = 0.0) -> None:
        self.position = position
        self.velocity = velocity
        self.target = position

    @property
    def done(self) -> bool:
        return self.position == self.target and self.velocity == 0.0

    def step(self, v_max: float, accel: float, decel: float, h: float) -> float:
        """Advance ``h`` [s]; the new position set-point.

        Parameters
        ----------
        v_max : float
            [rad/s] the profile velocity.
        accel, decel : float
            [rad/s^2].
        h : float
            [s].

        Returns
        -------
        float
            [rad] the new position set-point.
        """
        e = self.target - self.position
        if e == 0.0 and self.velocity == 0.0:
            return self.position
        direction = 1.0 if e > 0.0 else -1.0
        toward = self.velocity * direction  # > 0: moving toward the target
        if toward < 0.0:  # moving away: brake first
            toward = min(0.0, toward + decel * h)
        else:
            toward = min(v_max, toward + accel * h, math.sqrt(2.0 * decel * abs(e)))
        if toward * h >= abs(e):
            self.position, self.velocity = self.target, 0.0
        else:
            self.position += direction * toward * h
            self.velocity = direction * toward
        return self.position
