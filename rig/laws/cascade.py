"""``cascade-position``: the position and speed loops of section VII.D (reconstructed (6.36), Table V).

The position loop runs every ``position_every`` cycles, the speed loop every cycle;
the speed loop's q-current reference is sent as the torque k_t i_q* (CST).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from controllers.cascade import TABLE_V_POSITION, TABLE_V_SPEED, CascadeLoop
from drivers.base import Feedback
from rig.laws.base import Law, LawStep, Reference
from rig.papers import drives

__all__ = ["CascadeParams", "CascadePositionLaw"]


@dataclass(frozen=True)
class CascadeParams:
    k_t: float = drives.B_W * drives.J_IM  #: torque per q current [N m/A]: b_w J of Table V
    position_every: int = 2  #: the position loop's period in cycles (1 ms at 0.5 ms)

    def __post_init__(self) -> None:
        if self.position_every < 1:
            raise ValueError(f"position_every must be >= 1, got {self.position_every!r}")


class CascadePositionLaw(Law):
    Params = CascadeParams
    error_unit = "rad"
    modes = (frozenset({"cst"}),)
    position_reference = True
    internals = ("omega_ref", "i_q_ref")

    def __init__(self, params: CascadeParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        self.position, self.speed = CascadeLoop(TABLE_V_POSITION), CascadeLoop(TABLE_V_SPEED)
        self._k = 0
        self._omega_ref = 0.0

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        theta_r, _ = self.reference(t)
        fb = feedback[0]
        if self._k % self.params.position_every == 0:
            self._omega_ref = self.position.step(theta_r, fb.position, fb.velocity)
        self._k += 1
        i_q = self.speed.step(self._omega_ref, fb.velocity)
        return LawStep((self.params.k_t * i_q,), theta_r, fb.position, (self._omega_ref, i_q))
