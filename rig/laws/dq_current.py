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
from drivers.schema import key
from rig.laws.base import Law, LawParams, LawStep, Reference

__all__ = ["DqCurrentLaw", "DqLawParams"]


@dataclass(frozen=True)
class DqLawParams(LawParams):
    """The plant of Table IV the controller is tuned for, gamma of (34), the strategy and the line."""

    r1: float = key(0.36, "Ohm", "the plant's R_1", ge=0.0)
    l1: float = key(6e-3, "H", "the plant's L_1", gt=0.0)
    gamma: float = key(0.35, "", "the tuning factor of (34)", gt=0.0)
    strategy: Literal["s-pwm-start", "s-pwm-middle"] = key(
        "s-pwm-start", "", "(34), or (37) for s-PWM-middle"
    )
    f_line: float = key(50.0, "Hz", "the line frequency: omega_k = 2 pi f_line")
    u_max: float = key(math.inf, "V", "the converter's limit |u|", gt=0.0)


class DqCurrentLaw(Law):
    """The complex-vector current controller (32)-(34)/(37), or the dq PI, on a grid converter.

    Parameters
    ----------
    params : DqLawParams
        Its parameters.
    period : float
        [s] the loop's.
    reference : Reference
        The current reference.
    """

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
