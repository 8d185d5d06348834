"""Speed laws over one axis: ``pi-speed`` (PI with anti-windup) and ``idtsm-speed`` ((6.20)-(6.21)).

Both read the speed of the read axis (a CiA 406 encoder with ``speed_from_position``
gives it from the position) and command the effort of the commanded axis (torque in
CST, voltage in mode -1).
"""

from __future__ import annotations

from collections.abc import Sequence

from controllers.idtsm import IDTSM, IDTSMParams
from controllers.pi import PI, PIParams
from drivers.base import Feedback
from rig.laws.base import Law, LawStep, Reference

__all__ = ["IdtsmSpeedLaw", "PiSpeedLaw"]

_EFFORT = (frozenset({"cst", "voltage"}),)


class PiSpeedLaw(Law):
    """PI on the speed error; ``PIParams`` (kp, ki, u_max, u_min) with dt the loop period."""

    Params = PIParams
    modes = _EFFORT
    internals = ("integral",)

    def __init__(self, params: PIParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        self.pi = PI(params)

    def sensitivity(self) -> tuple[float, float]:
        """(0, |k_p| + k_i T): the PI's output per rad/s of speed in one period [unit of u/(rad/s)]."""
        p = self.params
        return (0.0, abs(p.kp) + p.ki * p.dt)

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        w_r, _ = self.reference(t)
        w = feedback[0].velocity
        u = self.pi.step(w_r - w)
        return LawStep((u,), w_r, w, (self.pi.integral,))


class IdtsmSpeedLaw(Law):
    """The integral DTSM (6.20)-(6.21) of dw/dt = a w + b u; ``IDTSMParams`` with dt the loop period.

    For a torque command a = -B/J, b = 1/J (Table II: a = -0.6286 1/s, b = 285.71 1/(kg m^2));
    for a voltage command a = -a_m, b = b_m of (3.5).
    """

    Params = IDTSMParams
    modes = _EFFORT

    def __init__(self, params: IDTSMParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        self.idtsm = IDTSM(params)

    def sensitivity(self) -> tuple[float, float]:
        """(0, |1/(b_delta T) + K_eq|): (6.20)-(6.21) move u by that per rad/s of speed in one period."""
        c = self.idtsm
        return (0.0, abs(1.0 / (c.b_delta * self.params.dt) + c.k_eq))

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        w_r, _ = self.reference(t)
        w = feedback[0].velocity
        return LawStep((self.idtsm.step(w_r - w),), w_r, w)
