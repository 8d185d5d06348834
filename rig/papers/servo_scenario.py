"""The DC position servo of section VII.B simulated: design (7.31) and law (7.30) on (3.7).

Lock-step and deterministic: one controller step, then one exact plant step per sample
(``rig.papers.scenarios``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.design import DTSMDesign, design_dtsm
from controllers.dtsm import DTSM, DTSMParams
from controllers.position_servo import PositionServo, PositionServoParams
from controllers.speed_observer import SpeedObserver
from plant_emulator.dc_motor import DCMotor, DCMotorParams, ReducedDCMotor
from plant_emulator.encoder import Encoder
from rig.host.references import smooth_move
from rig.laws import drives_paper as drives
from rig.papers.trajectory import Trajectory

__all__ = ["ServoScenario", "position_servo_run"]


@dataclass(frozen=True)
class ServoScenario:
    """The DC position servo of section VII.B: design (7.31) and law (7.30) on (3.7).

    ``load`` is the load as the disturbance f = T_L/J [rad/s^2] of (7.28), stepped on at
    ``load_time`` [s]. ``law="relay"`` replaces (7.30) by the sampled sign law
    u = -c A e - sigma sgn(g) (6.8) for comparison. ``counts_per_rev`` measures
    through an encoder (Euler-backward speed, or with ``observer_bandwidth`` [rad/s] the
    ``SpeedObserver`` on the encoder's position); ``full_motor`` uses (3.4) with
    an electrical time constant of 0.1 ms instead of (3.7).
    """

    a_m: float = drives.A_M  #: [1/s] of the plant (3.7)
    b_m: float = drives.B_M  #: [rad/(V s^2)] of the plant (3.7)
    dt: float = drives.T_SERVO  #: [s] the period
    lam: float = drives.LAMBDA_SERVO  #: [1/s] lambda of (7.31)
    sigma: float = drives.SIGMA  #: [V] the sign law's gain
    q: float = drives.Q  #: q of the design (7.31)
    rho: float = drives.RHO  #: rho of the design (7.31)
    h: float = drives.H  #: h of the design (7.31)
    u0: float = math.inf  #: [V] the bound (inf: none)
    distance: float = 10.0  #: [rad] the move
    move_time: float = 1.0  #: [s] its duration
    t_end: float = 3.0  #: [s] the run's length
    load: float = 0.0  #: [rad/s^2] f = T_L/J
    load_time: float = 1.5  #: [s] when the load steps on
    law: str = "7.30"  #: "7.30" or "relay"
    counts_per_rev: int | None = None  #: an encoder's (None: exact)
    full_motor: bool = False  #: (3.4) instead of (3.7)
    observer_bandwidth: float | None = None  #: [rad/s] the speed observer's (None: Euler backward)


def _dc_motor(a_m: float, b_m: float, dt: float, *, full: bool) -> tuple[DCMotor | ReducedDCMotor, float]:
    """(3.4) with a 0.1 ms electrical time constant, or (3.7) with J = 1; (motor, J)."""
    if full:
        full_motor = DCMotor(DCMotorParams.from_am_bm(a_m=a_m, b_m=b_m), dt=dt)
        return full_motor, full_motor.params.j
    return ReducedDCMotor(a_m=a_m, b_m=b_m, dt=dt, j=1.0), 1.0


def _servo_law(law: str, design: DTSMDesign, **gains: float) -> PositionServo | DTSM:
    """(7.30) (``law`` "7.30") or the sampled sign law (6.8) ("relay") for ``design`` (7.31)."""
    if law == "7.30":
        return PositionServo(PositionServoParams(design=design, **gains))
    if law == "relay":
        return DTSM(DTSMParams(design=design, law="relay", sigma=gains["sigma"], u0=gains["u0"]))
    raise ValueError(f"law must be '7.30' or 'relay', got {law!r}")


@dataclass
class _Sensing:
    """What the law sees of the shaft: the exact state, an encoder's, or the observer's speed."""

    encoder: Encoder | None
    observer: SpeedObserver | None

    @classmethod
    def of(cls, s: ServoScenario) -> _Sensing:
        """The encoder and speed observer ``s`` names (None where it names none)."""
        encoder = Encoder(s.counts_per_rev, dt=s.dt) if s.counts_per_rev else None
        if s.observer_bandwidth is None:
            return cls(encoder, None)
        return cls(encoder, SpeedObserver(s.a_m, s.b_m, dt=s.dt, bandwidth=s.observer_bandwidth))

    def measure(self, theta: float, omega: float) -> tuple[float, float]:
        """(position [rad], speed [rad/s]) measured of the true ``theta``, ``omega``."""
        if self.encoder is not None:
            theta, omega = self.encoder.sample(theta)
        if self.observer is not None:
            omega = self.observer.update(theta)
        return theta, omega

    def command(self, u: float) -> None:
        """Tell the observer the command ``u`` [V] just given."""
        if self.observer is not None:
            self.observer.command(u)


def position_servo_run(**options: Any) -> Trajectory:
    """Simulate the DC position servo of section VII.B (``ServoScenario``) for its ``t_end``.

    Parameters
    ----------
    **options : Any
        ``ServoScenario``'s fields by name (not given: the paper's values).

    Returns
    -------
    Trajectory
        The run; ``extra``: ``u_i`` (the law's integral part) and ``sign_law`` (1 where the law
        was in its sign mode).

    Raises
    ------
    ValueError
        If the law is neither "7.30" nor "relay".
    """
    s = ServoScenario(**options)
    design = design_dtsm(A=[[0.0, 1.0], [0.0, -s.a_m]], b=[0.0, -s.b_m], dt=s.dt, lam=s.lam)
    ctl = _servo_law(s.law, design, sigma=s.sigma, q=s.q, rho=s.rho, h=s.h, u0=s.u0)
    motor, j = _dc_motor(s.a_m, s.b_m, s.dt, full=s.full_motor)
    sensing = _Sensing.of(s)
    ref = smooth_move(s.distance, s.move_time)
    n = round(s.t_end / s.dt)
    t = np.arange(n) * s.dt
    out = {k: np.empty(n) for k in ("ref", "y", "u", "g", "u_i", "sign_law")}
    for k in range(n):
        tk = k * s.dt
        theta_r, omega_r = ref(tk)
        theta, omega = sensing.measure(motor.theta, motor.omega)
        u = ctl.step(theta_r - theta, omega_r - omega)
        sensing.command(u)
        out["ref"][k], out["y"][k], out["u"][k] = theta_r, motor.theta, u
        out["g"][k] = ctl.g
        out["u_i"][k] = getattr(ctl, "u_i", 0.0)
        out["sign_law"][k] = 0.0 if ctl.linear else 1.0
        motor.step(u, j * s.load if tk >= s.load_time else 0.0)
    extra = {"u_i": out["u_i"], "sign_law": out["sign_law"]}
    return Trajectory(t, out["ref"], out["y"], out["u"], out["g"], extra)
