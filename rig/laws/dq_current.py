"""``dq-current``: the complex-vector current controller (32)-(34), or (37) for s-PWM-middle, over CAN.

The reference is i_q* [A] (i_d* = 0); the commanded axis is in mode ``dq-voltage``
and takes the complex u_dq [V]; the read axis gives i_dq.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from controllers.dq_current import ComplexVectorCurrentController, DqCurrentParams
from drivers.base import Feedback
from rig.laws.base import Law, LawStep, Reference

__all__ = ["DqCurrentLaw", "DqLawParams"]


@dataclass(frozen=True)
class DqLawParams:
    """The plant of Table IV the controller is tuned for, gamma of (34), the strategy and the line."""

    r1: float = 0.36  #: [Ohm]
    l1: float = 6e-3  #: [H]
    gamma: float = 0.35  #: tuning factor of (34)
    strategy: Literal["s-pwm-start", "s-pwm-middle"] = "s-pwm-start"  #: (34), or (37) for the middle
    f_line: float = 50.0  #: [Hz] omega_k = 2 pi f_line
    u_max: float = math.inf  #: converter limit |u| [V]


class DqCurrentLaw(Law):
    Params = DqLawParams
    error_unit = "A"
    modes = (frozenset({"dq-voltage"}),)
    internals = ("i_d", "u_d", "u_q")

    def __init__(self, params: DqLawParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        p = params
        self.ctl = ComplexVectorCurrentController(
            DqCurrentParams(p.r1, p.l1, period, p.gamma, p.strategy, p.u_max)
        )
        self.omega_k = 2.0 * math.pi * p.f_line

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        i_q_ref, _ = self.reference(t)
        i_dq = feedback[0].i_dq or 0j
        u = self.ctl.step(1j * i_q_ref, i_dq, self.omega_k)
        return LawStep((u,), i_q_ref, i_dq.imag, (i_dq.real, u.real, u.imag))
