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
from drivers.schema import Refused, key
from rig.laws import drives_paper as drives
from rig.laws.base import SIGN_LAW, Law, LawParams, LawStep, Reference

__all__ = ["PositionServoLaw", "ServoParams"]


@dataclass(frozen=True)
class ServoParams(LawParams):
    """The model (3.5) the design (7.31) is made for, and the gains of (7.30)."""

    a_m: float = key(drives.A_M, "1/s", "the model (3.5): dw/dt = -a_m w + b_m u")
    b_m: float = key(drives.B_M, "rad/(V s^2)", "(3.5); per N m when the axis is in CST", nonzero=True)
    lam: float = key(drives.LAMBDA_SERVO, "1/s", "the sliding eigenvalue of the design (7.31)", lt=0.0)
    sigma: float = key(drives.SIGMA, "V", "the reaching bound of (7.30) (the sign law's gain)", gt=0.0)
    q: float = key(drives.Q, "V/(V s)", "the proportional reaching gain of (7.30)", ge=0.0)
    rho: float = key(drives.RHO, "rad/s", "the speed-error threshold of the integral of (7.30)", gt=0.0)
    h: float = key(drives.H, "1/s", "the integral gain of (7.30), below 1/T", ge=0.0)
    u0: float = key(math.inf, "V", "the output limit", gt=0.0)
    speed: Literal["drive", "observer"] = key(
        "drive",
        "",
        "the speed the law uses: the axis's velocity feedback (drive) or estimated from the position "
        "by controllers.speed_observer on this model (observer, for quantised encoders)",
    )
    observer_bandwidth: float = key(500.0, "rad/s", "the observer's poles", gt=0.0)
    observer_delay: int = key(0, "periods", "from the law's command to the drive applying it", ge=0, le=10)
    law: Literal["7.30", "sign"] = key("7.30", "", "(7.30), or the sign law (6.8) with gain sigma")

    def rules(self, period: float) -> None:
        """(7.30d): 0 <= h < 1/T.

        Parameters
        ----------
        period : float
            [s] the run's.

        Raises
        ------
        Refused
            If h is not in [0, 1/T).
        """
        if not self.h < 1.0 / period:
            raise Refused("h", self.h, f"must be below 1/T = {1.0 / period:g} 1/s (7.30d)")


class PositionServoLaw(Law):
    """theta_r - theta and omega_r - omega of the read axis -> u (7.30) of the commanded axis.

    Parameters
    ----------
    params : ServoParams
        Its parameters.
    period : float
        [s] the loop's.
    reference : Reference
        The position reference.
    """

    Params = ServoParams
    error_unit = "rad"
    modes = (frozenset({"voltage", "cst"}),)
    position_reference = True
    internals = ("g", "u_i", SIGN_LAW)

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
        self.observer = (
            SpeedObserver(p.a_m, p.b_m, dt=period, bandwidth=p.observer_bandwidth, delay=p.observer_delay)
            if p.speed == "observer"
            else None
        )
        (c1, c2), (k1, k2) = design.c_delta, design.c_delta_A_delta
        if p.law == "sign":  # the continuous part -c_delta A_delta e only
            s1, s2 = k1, k2
        else:  # linear mode of (7.30): u = -(k + c/T + h c) e
            inv_dt = 1.0 / period
            s1, s2 = k1 + (inv_dt + p.h) * c1, k2 + (inv_dt + p.h) * c2
        observer = self.observer
        self._t_last: float | None = None  #: [s] the time of the latest step
        # with the observer the law reads no speed: a count of position moves its estimate by gain[1]
        self._sensitivity = (abs(s1), abs(s2)) if observer is None else (abs(s1 + s2 * observer.gain[1]), 0.0)

    def sensitivity(self) -> tuple[float, float]:
        """|du/de_1| [V/rad] and |du/de_2| [V/(rad/s)] of (7.30)'s linear mode,
        -(c_delta A_delta + (1/T + h) c_delta) (the integral's step h g included); of the
        sign law, its continuous part -c_delta A_delta. With ``speed = "observer"`` the law reads
        the position only: (|du/de_1 + du/de_2 l_w|, 0), l_w the observer's speed gain per rad
        of a new sample (``SpeedObserver.gain``).

        Returns
        -------
        tuple[float, float]
            (|du/de_1|, |du/de_2|).
        """
        return self._sensitivity

    def held(self, commands: Sequence[complex | float]) -> None:
        """The observer predicts the periods until the next step with the command sent.

        Parameters
        ----------
        commands : Sequence[complex | float]
            What the commanded axis was sent.
        """
        if self.observer is not None:
            self.observer.hold(commands[0].real)

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        theta_r, omega_r = self.reference(t)
        fb = feedback[0]
        servo, observer = self.servo, self.observer
        if observer is None:
            omega = fb.velocity
        else:
            last, self._t_last = self._t_last, t
            if last is not None:  # periods that passed without a step (skipped, or late)
                observer.coast(max(0, round((t - last) / self.period) - 1))
            omega = observer.update(fb.position)
        u = servo.step(theta_r - fb.position, omega_r - omega)
        if observer is not None:
            observer.command(u)
        sign = 0.0 if servo.linear else 1.0
        return LawStep((u,), theta_r, fb.position, (servo.g, getattr(servo, "u_i", 0.0), sign))
