"""``position-servo``: the DC position servo of section VII.B, law (7.30) with the design (7.31).

``law = "sign"`` runs the sampled sign law (6.8), u = -c_delta A_delta e - sigma sgn(g), on the
same design instead: the chattering counter-example of section VI over the wire.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from controllers.design import design_dtsm
from controllers.dtsm import DTSM, DTSMParams
from controllers.position_servo import PositionServo, PositionServoParams
from controllers.speed_observer import SpeedObserver
from drivers.base import Feedback
from rig.laws.base import Law, LawStep, Reference
from rig.papers import drives

__all__ = ["PositionServoLaw", "ServoParams"]


@dataclass(frozen=True)
class ServoParams:
    """The model (3.5) the design (7.31) is made for, and the gains of (7.30)."""

    a_m: float = drives.A_M  #: [1/s]
    b_m: float = drives.B_M  #: [rad/(V s^2)] (per N m when the axis is in CST)
    lam: float = drives.LAMBDA_SERVO  #: sliding eigenvalue [1/s], < 0
    sigma: float = drives.SIGMA  #: reaching bound [V]
    q: float = drives.Q  #: proportional reaching gain [V/(V s)]
    rho: float = drives.RHO  #: speed-error threshold of the integral [rad/s]
    h: float = drives.H  #: integral gain [1/s], 0 <= h < 1/T
    u0: float = math.inf  #: output limit [V]
    #: the speed the law uses: "drive" (the axis's velocity feedback) or "observer" (estimated
    #: from the position by ``controllers.speed_observer`` on this model, for quantised encoders)
    speed: str = "drive"
    observer_bandwidth: float = 500.0  #: [rad/s] the observer's poles
    observer_delay: int = 0  #: [periods] from the law's command to the drive applying it
    law: Literal["7.30", "sign"] = "7.30"  #: (7.30), or the sign law (6.8) with gain sigma


class PositionServoLaw(Law):
    """theta_r - theta and omega_r - omega of the read axis -> u (7.30) of the commanded axis."""

    Params = ServoParams
    error_unit = "rad"
    modes = (frozenset({"voltage", "cst"}),)
    position_reference = True
    internals = ("g", "u_i")

    def __init__(self, params: ServoParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        p = params
        design = design_dtsm(A=[[0.0, 1.0], [0.0, -p.a_m]], b=[0.0, -p.b_m], dt=period, lam=p.lam)
        self.servo: PositionServo | DTSM
        if p.law == "sign":
            self.servo = DTSM(DTSMParams(design=design, law="relay", sigma=p.sigma, u0=p.u0))
        else:
            self.servo = PositionServo(
                PositionServoParams(design=design, sigma=p.sigma, q=p.q, rho=p.rho, h=p.h, u0=p.u0)
            )
        if p.speed not in ("drive", "observer"):
            raise ValueError(f"speed = {p.speed!r}: drive or observer")
        self.observer = (
            SpeedObserver(p.a_m, p.b_m, dt=period, bandwidth=p.observer_bandwidth, delay=p.observer_delay)
            if p.speed == "observer"
            else None
        )
        (c1, c2), (k1, k2) = design.c_delta, design.c_delta_A_delta
        if p.law == "sign":  # the continuous part -c_delta A_delta e only
            self._sensitivity = (abs(k1), abs(k2))
        else:  # linear mode of (7.30): u = -(k + c/T + h c) e
            inv_dt = 1.0 / period
            self._sensitivity = (abs(k1 + (inv_dt + p.h) * c1), abs(k2 + (inv_dt + p.h) * c2))

    def sensitivity(self) -> tuple[float, float]:
        """|du/de_1| [V/rad] and |du/de_2| [V/(rad/s)] of (7.30)'s linear mode,
        -(c_delta A_delta + (1/T + h) c_delta) (the integral's step h g included); of the
        sign law, its continuous part -c_delta A_delta."""
        return self._sensitivity

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        theta_r, omega_r = self.reference(t)
        fb = feedback[0]
        servo, observer = self.servo, self.observer
        omega = fb.velocity if observer is None else observer.update(fb.position)
        u = servo.step(theta_r - fb.position, omega_r - omega)
        if observer is not None:
            observer.command(u)
        return LawStep((u,), theta_r, fb.position, (servo.g, getattr(servo, "u_i", 0.0)))
