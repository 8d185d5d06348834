"""Closed-loop simulations of the drives paper's experiments, controller against physics.

Lock-step and deterministic: one controller step, then one exact plant step
per sample. These join ``controllers`` and ``plant_emulator`` without a bus;
the over-the-wire runs (later issues) must give the same trajectories.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from controllers.cascade import (
    TABLE_V_CURRENT,
    TABLE_V_POSITION,
    TABLE_V_SPEED,
    Cascade,
    CascadeLoop,
    CascadeLoopParams,
)
from controllers.compensators import FirstOrderCompensator, SecondOrderCompensator
from controllers.design import DTSMDesign, design_dtsm
from controllers.dtsm import DTSM, DTSMParams
from controllers.position_servo import PositionServo, PositionServoParams
from controllers.speed_observer import SpeedObserver
from plant_emulator.dc_motor import DCMotor, DCMotorParams, ReducedDCMotor
from plant_emulator.encoder import Encoder
from rig.host.references import smooth_move
from rig.laws import drives_paper as drives

__all__ = [
    "Trajectory",
    "cascade_run",
    "position_servo_run",
    "speed_loop_run",
]


@dataclass
class Trajectory:
    """Sampled closed-loop signals, one row per controller sample (SI units)."""

    t: np.ndarray  #: time [s]
    ref: np.ndarray  #: reference of the controlled variable
    y: np.ndarray  #: controlled variable (true, not measured)
    u: np.ndarray  #: control output of the outermost controller called
    g: np.ndarray  #: sliding variable g_k
    extra: dict[str, np.ndarray] = field(default_factory=dict)  #: other signals by name

    @property
    def error(self) -> np.ndarray:
        """Tracking error ref - y."""
        err: np.ndarray = self.ref - self.y
        return err

    def window(self, t0: float, t1: float = math.inf) -> np.ndarray:
        """Boolean mask of the samples with t0 <= t < t1.

        Parameters
        ----------
        t0 : float
            [s].
        t1 : float, optional
            [s].

        Returns
        -------
        np.ndarray
            The mask.
        """
        mask: np.ndarray = (self.t >= t0) & (self.t < t1)
        return mask


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


def position_servo_run(
    *,
    a_m: float = drives.A_M,
    b_m: float = drives.B_M,
    dt: float = drives.T_SERVO,
    lam: float = drives.LAMBDA_SERVO,
    sigma: float = drives.SIGMA,
    q: float = drives.Q,
    rho: float = drives.RHO,
    h: float = drives.H,
    u0: float = math.inf,
    distance: float = 10.0,
    move_time: float = 1.0,
    t_end: float = 3.0,
    load: float = 0.0,
    load_time: float = 1.5,
    law: str = "7.30",
    counts_per_rev: int | None = None,
    full_motor: bool = False,
    observer_bandwidth: float | None = None,
) -> Trajectory:
    """The DC position servo of section VII.B: design (7.31) and law (7.30) on (3.7).

    ``load`` is the load as the disturbance f = T_L/J [rad/s^2] of (7.28), stepped on at
    ``load_time`` [s]. ``law="relay"`` replaces (7.30) by the sampled sign law
    u = -c A e - sigma sgn(g) (6.8) for comparison. ``counts_per_rev`` measures
    through an encoder (Euler-backward speed, or with ``observer_bandwidth`` [rad/s] the
    ``SpeedObserver`` on the encoder's position); ``full_motor`` uses (3.4) with
    an electrical time constant of 0.1 ms instead of (3.7).

    Parameters
    ----------
    a_m, b_m : float, optional
        The plant (3.7).
    dt : float, optional
        [s] the period.
    lam : float, optional
        [1/s] lambda of (7.31).
    sigma : float, optional
        [V] the sign law's gain.
    q, rho, h : float, optional
        The design's parameters (7.31).
    u0 : float, optional
        [V] the bound (inf: none).
    distance : float, optional
        [rad] the move.
    move_time : float, optional
        [s] its duration.
    t_end : float, optional
        [s].
    load : float, optional
        [rad/s^2] f = T_L/J.
    load_time : float, optional
        [s] when it steps on.
    law : str, optional
        "7.30" or "relay".
    counts_per_rev : int | None, optional
        An encoder's (None: exact).
    full_motor : bool, optional
        (3.4) instead of (3.7).
    observer_bandwidth : float | None, optional
        [rad/s] the speed observer's (None: Euler backward).

    Returns
    -------
    Trajectory
        The run.
    """
    design = design_dtsm(A=[[0.0, 1.0], [0.0, -a_m]], b=[0.0, -b_m], dt=dt, lam=lam)
    ctl = _servo_law(law, design, sigma=sigma, q=q, rho=rho, h=h, u0=u0)
    motor, j = _dc_motor(a_m, b_m, dt, full=full_motor)
    encoder = Encoder(counts_per_rev, dt=dt) if counts_per_rev else None
    observer = (
        None if observer_bandwidth is None else SpeedObserver(a_m, b_m, dt=dt, bandwidth=observer_bandwidth)
    )
    ref = smooth_move(distance, move_time)
    n = round(t_end / dt)
    t = np.arange(n) * dt
    out = {k: np.empty(n) for k in ("ref", "y", "u", "g", "u_i", "sign_law")}
    for k in range(n):
        tk = k * dt
        theta_r, omega_r = ref(tk)
        theta, omega = motor.theta, motor.omega
        if encoder is not None:
            theta, omega = encoder.sample(theta)
        if observer is not None:
            omega = observer.update(theta)
        u = ctl.step(theta_r - theta, omega_r - omega)
        if observer is not None:
            observer.command(u)
        out["ref"][k], out["y"][k], out["u"][k] = theta_r, motor.theta, u
        out["g"][k] = ctl.g
        out["u_i"][k] = getattr(ctl, "u_i", 0.0)
        out["sign_law"][k] = 0.0 if ctl.linear else 1.0
        motor.step(u, j * load if tk >= load_time else 0.0)
    extra = {"u_i": out["u_i"], "sign_law": out["sign_law"]}
    return Trajectory(t, out["ref"], out["y"], out["u"], out["g"], extra)


def speed_loop_run(
    *,
    compensator: str = "none",
    alpha: float = 1.0,
    a_m: float = drives.A_M,
    b_m: float = drives.B_M,
    dt: float = 1e-3,
    t_end: float = 4.0,
    disturbance: Callable[[float], float] | None = None,
    substeps: int = 20,
    held_disturbance: bool = False,
    law: Literal["deadbeat", "bounded"] = "deadbeat",
    sigma: float = math.inf,
    speed_step: float = 0.0,
) -> Trajectory:
    """Speed control of (3.5) under a matched disturbance (Fig. 9).

    The reference is ``speed_step`` [rad/s] from t = 0 (0: regulation at zero); the DTSM
    works on x = omega - omega_ref, so the reference enters (3.5) as the constant matched
    term a_m omega_ref / b_m, which the compensators remove and the law alone does not.
    DTSM ``law`` (6.14) ("deadbeat") or (6.15a) ("bounded", reaching bound ``sigma`` [V])
    on the first-order design (c_delta = 1/b_delta), with (6.15a) the compensator acting in its
    linear mode only (``DTSMParams.compensate``), with compensator
    ``"none"``, ``"first"`` (6.30b, gain ``alpha``) or ``"second"`` (6.35). The
    disturbance f(t) [V] defaults to 5 h(t-2) sin(5t); the plant integrates it
    with ``substeps`` exact sub-steps per sample, or holds f(kT) over each
    sample when ``held_disturbance`` (then d_k = f(kT) exactly in (6.22)).
    Returns y = omega, and in ``extra["d"]`` the disturbance d_k the step saw.

    Parameters
    ----------
    compensator : str, optional
        "none", "first" or "second".
    alpha : float, optional
        The first's gain.
    a_m, b_m : float, optional
        The plant (3.5).
    dt : float, optional
        [s] the period.
    t_end : float, optional
        [s].
    disturbance : Callable[[float], float] | None, optional
        f(t) [V] (None: 5 h(t-2) sin(5t)).
    substeps : int, optional
        Exact sub-steps per sample.
    held_disturbance : bool, optional
        f(kT) held over each sample.
    law : Literal['deadbeat', 'bounded'], optional
        "deadbeat" (6.14) or "bounded" (6.15a).
    sigma : float, optional
        [V] the reaching bound.
    speed_step : float, optional
        [rad/s] the reference.

    Returns
    -------
    Trajectory
        The run.

    Raises
    ------
    ValueError
        If the compensator or the law is unknown.
    """
    f = disturbance or (lambda t: 5.0 * math.sin(5.0 * t) if t >= 2.0 else 0.0)
    design = design_dtsm(A=[[-a_m]], b=[b_m], dt=dt, lam=-1.0)
    comp: FirstOrderCompensator | SecondOrderCompensator | None
    if compensator == "none":
        comp = None
    elif compensator == "first":
        comp = FirstOrderCompensator(alpha=alpha, dt=dt)
    elif compensator == "second":
        comp = SecondOrderCompensator(dt=dt)
    else:
        raise ValueError(f"compensator must be 'none', 'first' or 'second', got {compensator!r}")
    compensate: Literal["always", "linear"] = "linear" if law == "bounded" else "always"
    ctl = DTSM(DTSMParams(design=design, law=law, sigma=sigma, compensate=compensate), compensator=comp)
    sub = 1 if held_disturbance else substeps
    motor = ReducedDCMotor(a_m=a_m, b_m=b_m, dt=dt / sub)
    n = round(t_end / dt)
    t = np.arange(n) * dt
    y, u_out, g, d = (np.empty(n) for _ in range(4))
    for k in range(n):
        u = ctl.step(motor.omega - speed_step)
        y[k], u_out[k], g[k] = motor.omega, u, ctl.g
        if held_disturbance:
            d[k] = f(k * dt)
            motor.step(u, f=d[k])
        else:
            d[k] = math.nan
            for i in range(sub):
                motor.step(u, f=f((k + (i + 0.5) / sub) * dt))
    return Trajectory(t, np.full(n, speed_step), y, u_out, g, {"d": d})


def _cascade(position: CascadeLoopParams, speed: CascadeLoopParams, current: CascadeLoopParams) -> Cascade:
    """The three loops of section VII.D, the outer two run every speed.dt and position.dt."""
    return Cascade(
        CascadeLoop(position),
        CascadeLoop(speed),
        CascadeLoop(current),
        speed_every=round(speed.dt / current.dt),
        position_every=round(position.dt / current.dt),
    )


def cascade_run(
    *,
    position: CascadeLoopParams = TABLE_V_POSITION,
    speed: CascadeLoopParams = TABLE_V_SPEED,
    current: CascadeLoopParams = TABLE_V_CURRENT,
    a_i: float = -233.8936,
    b_i: float = 42.8992,
    a_w: float = -0.6286,
    b_w: float = drives.B_W,
    j: float = drives.J_IM,
    distance: float = 10.0,
    move_time: float = 1.0,
    t_end: float = 3.0,
    load: Callable[[float], float] | None = None,
    counts_per_rev: int | None = None,
    move_start: float = 0.0,
) -> Trajectory:
    """The IM cascade of section VII.D on the field-oriented reduced model (4.9).

    With rotor-flux orientation and decoupling, (4.9) is a DC motor without
    back-EMF: i_q' = a_i i_q + b_i u_q, omega' = a_w omega + b_w i_q - T_L/J,
    theta' = omega, with Table V's a_i, b_i, a_w, b_w and J of Table II.
    ``load(t)`` [N m] defaults to zero; the move starts at ``move_start`` [s]. Sampled every
    0.1 ms (current loop); speed every 0.5 ms, position every 1 ms. ``counts_per_rev``: an
    encoder, speed by Euler backward.

    Parameters
    ----------
    position, speed, current : CascadeLoopParams, optional
        The loops' parameters (Table V).
    a_i, b_i, a_w, b_w : float, optional
        Of (4.9), Table V.
    j : float, optional
        [kg m^2] J of Table II.
    distance : float, optional
        [rad] the move.
    move_time : float, optional
        [s] its duration.
    t_end : float, optional
        [s].
    load : Callable[[float], float] | None, optional
        T_L [N m] of time [s] (None: 0).
    counts_per_rev : int | None, optional
        An encoder's (None: exact).
    move_start : float, optional
        [s].

    Returns
    -------
    Trajectory
        The run.
    """
    dt = current.dt
    fo = DCMotorParams(r_r=-a_i / b_i, l_r=1.0 / b_i, k_e=0.0, k_t=b_w * j, j=j, b=-a_w * j)  # (4.9)
    motor = DCMotor(fo, dt=dt)
    ctl = _cascade(position, speed, current)
    encoder = Encoder(counts_per_rev, dt=speed.dt) if counts_per_rev else None
    ref, load = smooth_move(distance, move_time, move_start), load or (lambda t: 0.0)
    n = round(t_end / dt)
    t = np.arange(n) * dt
    names = ("ref", "y", "u", "g", "omega_ref", "omega", "i_ref", "i_q", "sign_law")
    out = {k: np.empty(n) for k in names}
    theta_m, omega_m = 0.0, 0.0
    for k in range(n):
        tk = k * dt
        if encoder is None:
            theta_m, omega_m = motor.theta, motor.omega
        elif k % ctl.speed_every == 0:
            theta_m, omega_m = encoder.sample(motor.theta)
        theta_r = ref(tk)[0]
        u = ctl.step(theta_r, theta_m, omega_m, motor.current)
        outside = 0.0 if ctl.position.linear and ctl.speed.linear else 1.0  # the loops the host runs
        row = (
            theta_r,
            motor.theta,
            u,
            ctl.position.g,
            ctl.omega_ref,
            motor.omega,
            ctl.i_ref,
            motor.current,
            outside,
        )
        for name, value in zip(names, row):
            out[name][k] = value
        motor.step(u, load(tk))
    return Trajectory(t, out["ref"], out["y"], out["u"], out["g"], {k: out[k] for k in names[4:]})
