"""Speed laws over one axis: ``pi-speed`` (PI with anti-windup) and ``idtsm-speed`` ((6.20)-(6.21)).

Both read the speed of the read axis (a CiA 406 encoder with ``speed_from_position``
gives it from the position) and command the effort of the commanded axis (torque in
CST, voltage in mode -1).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from controllers.idtsm import IDTSM, IDTSMParams
from controllers.pi import PI, PIParams
from drivers.base import Feedback
from drivers.schema import Refused, key
from rig.laws.base import SIGN_LAW, Law, LawParams, LawStep, Reference

__all__ = ["IdtsmSpeedLaw", "IdtsmSpeedParams", "PiSpeedLaw", "PiSpeedParams"]

_EFFORT = (frozenset({"cst", "voltage"}),)


@dataclass(frozen=True)
class PiSpeedParams(LawParams):
    """The PI's gains and limits (``controllers.pi.PIParams``; T is the run's period)."""

    kp: float = key(unit="unit of u/(rad/s)", doc="the proportional gain")
    ki: float = key(unit="unit of u/(rad/s s)", doc="the integral gain", ge=0.0)
    u_max: float = key(math.inf, "unit of u", "the upper output limit")
    u_min: float = key(-math.inf, "unit of u", "the lower output limit, below u_max")

    def rules(self, period: float) -> None:
        """u_min < u_max.

        Parameters
        ----------
        period : float
            [s] the run's.

        Raises
        ------
        Refused
            If u_min >= u_max.
        """
        if not self.u_min < self.u_max:
            raise Refused("u_min", self.u_min, f"must be below u_max = {self.u_max!r}")


@dataclass(frozen=True)
class IdtsmSpeedParams(LawParams):
    """The integral DTSM's plant dw/dt = a w + b u and design (``controllers.idtsm.IDTSMParams``;
    T is the run's period): for a torque command a = -B/J, b = 1/J; for a voltage a = -a_m, b = b_m."""

    a: float = key(unit="1/s", doc="the plant's pole (-a_m of (3.5))")
    b: float = key(unit="rad/s^2 per unit of u", doc="the plant's input gain (b_m of (3.5))", nonzero=True)
    lam: float = key(unit="1/s", doc="the desired eigenvalue lambda", lt=0.0)
    g_limit: float = key(math.inf, "unit of u s", "the bound on the integrator |g|", gt=0.0)
    u0: float = key(math.inf, "unit of u", "the output limit |u|", gt=0.0)


class PiSpeedLaw(Law):
    """PI on the speed error (``PiSpeedParams``) at the loop period.

    Parameters
    ----------
    params : PiSpeedParams
        Its parameters.
    period : float
        [s] the loop's.
    reference : Reference
        The speed reference.
    """

    Params = PiSpeedParams
    modes = _EFFORT
    internals = ("integral",)

    def __init__(self, params: PiSpeedParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        p = params
        self.pi = PI(PIParams(p.kp, p.ki, period, p.u_max, p.u_min))

    def sensitivity(self) -> tuple[float, float]:
        """(0, |k_p| + k_i T): the PI's output per rad/s of speed in one period [unit of u/(rad/s)].

        Returns
        -------
        tuple[float, float]
            (0, |k_p| + k_i T).
        """
        p = self.params
        return (0.0, abs(p.kp) + p.ki * self.period)

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        w_r, _ = self.reference(t)
        w = feedback[0].velocity
        u = self.pi.step(w_r - w)
        return LawStep((u,), w_r, w, (self.pi.integral,))


class IdtsmSpeedLaw(Law):
    """The integral DTSM (6.20)-(6.21) of dw/dt = a w + b u (``IdtsmSpeedParams``) at the loop period.

    For a torque command a = -B/J, b = 1/J (Table II: a = -0.6286 1/s, b = 285.71 1/(kg m^2));
    for a voltage command a = -a_m, b = b_m of (3.5).

    Parameters
    ----------
    params : IdtsmSpeedParams
        Its parameters.
    period : float
        [s] the loop's.
    reference : Reference
        The speed reference.
    """

    Params = IdtsmSpeedParams
    modes = _EFFORT
    internals = (SIGN_LAW,)

    def __init__(self, params: IdtsmSpeedParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        p = params
        self.idtsm = IDTSM(IDTSMParams(p.a, p.b, period, p.lam, p.g_limit, p.u0))

    def sensitivity(self) -> tuple[float, float]:
        """(0, |1/(b_delta T) + K_eq|): (6.20)-(6.21) move u by that per rad/s of speed in one period.

        Returns
        -------
        tuple[float, float]
            (0, |1/(b_delta T) + K_eq|).
        """
        c = self.idtsm
        return (0.0, abs(1.0 / (c.b_delta * self.period) + c.k_eq))

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        w_r, _ = self.reference(t)
        w = feedback[0].velocity
        c = self.idtsm
        u = c.step(w_r - w)
        return LawStep((u,), w_r, w, (0.0 if c.linear else 1.0,))
