"""The IM cascade of section VII.D simulated on the field-oriented reduced model (4.9).

Lock-step and deterministic: one controller step, then one exact plant step per sample
(``rig.papers.scenarios``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.cascade import (
    TABLE_V_CURRENT,
    TABLE_V_POSITION,
    TABLE_V_SPEED,
    Cascade,
    CascadeLoop,
    CascadeLoopParams,
)
from plant_emulator.dc_motor import DCMotor, DCMotorParams
from plant_emulator.encoder import Encoder
from rig.host.references import smooth_move
from rig.laws import drives_paper as drives
from rig.papers.trajectory import Trajectory

__all__ = ["CascadeScenario", "cascade_run"]

#: the signals recorded each sample, in ``_row``'s order: Trajectory's four, then its extra
_SIGNALS = ("ref", "y", "u", "g", "omega_ref", "omega", "i_ref", "i_q", "sign_law")


@dataclass(frozen=True)
class CascadeScenario:
    """The IM cascade of section VII.D on the field-oriented reduced model (4.9).

    With rotor-flux orientation and decoupling, (4.9) is a DC motor without
    back-EMF: i_q' = a_i i_q + b_i u_q, omega' = a_w omega + b_w i_q - T_L/J,
    theta' = omega, with Table V's a_i, b_i, a_w, b_w and J of Table II.
    ``load(t)`` [N m] defaults to zero; the move starts at ``move_start`` [s]. Sampled every
    0.1 ms (current loop); speed every 0.5 ms, position every 1 ms. ``counts_per_rev``: an
    encoder, speed by Euler backward.
    """

    position: CascadeLoopParams = TABLE_V_POSITION  #: the position loop's parameters (Table V)
    speed: CascadeLoopParams = TABLE_V_SPEED  #: the speed loop's parameters (Table V)
    current: CascadeLoopParams = TABLE_V_CURRENT  #: the current loop's parameters (Table V)
    a_i: float = -233.8936  #: [1/s] of (4.9), Table V
    b_i: float = 42.8992  #: [A/(V s)] of (4.9), Table V
    a_w: float = -0.6286  #: [1/s] of (4.9), Table V
    b_w: float = drives.B_W  #: [rad/(A s^2)] of (4.9), Table V
    j: float = drives.J_IM  #: [kg m^2] J of Table II
    distance: float = 10.0  #: [rad] the move
    move_time: float = 1.0  #: [s] its duration
    t_end: float = 3.0  #: [s] the run's length
    load: Callable[[float], float] | None = None  #: T_L [N m] of time [s] (None: 0)
    counts_per_rev: int | None = None  #: an encoder's (None: exact)
    move_start: float = 0.0  #: [s] when the move starts


def _cascade(position: CascadeLoopParams, speed: CascadeLoopParams, current: CascadeLoopParams) -> Cascade:
    """The three loops of section VII.D, the outer two run every speed.dt and position.dt."""
    return Cascade(
        CascadeLoop(position),
        CascadeLoop(speed),
        CascadeLoop(current),
        speed_every=round(speed.dt / current.dt),
        position_every=round(position.dt / current.dt),
    )


def _motor(s: CascadeScenario) -> DCMotor:
    """(4.9) as a DC motor without back-EMF, sampled at the current loop's period."""
    fo = DCMotorParams(r_r=-s.a_i / s.b_i, l_r=1.0 / s.b_i, k_e=0.0, k_t=s.b_w * s.j, j=s.j, b=-s.a_w * s.j)
    return DCMotor(fo, dt=s.current.dt)


def _no_load(t: float) -> float:
    """T_L = 0 [N m] at every time ``t`` [s]."""
    return 0.0


def _row(ctl: Cascade, motor: DCMotor, theta_r: float, u: float) -> tuple[float, ...]:
    """The sample's signals in ``_SIGNALS``' order (sign_law: 1 where a loop the host runs is in its
    sign mode)."""
    outside = 0.0 if ctl.position.linear and ctl.speed.linear else 1.0  # the loops the host runs
    return (
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


def cascade_run(**options: Any) -> Trajectory:
    """Simulate the IM cascade of section VII.D (``CascadeScenario``) for its ``t_end``.

    Parameters
    ----------
    **options : Any
        ``CascadeScenario``'s fields by name (not given: Table V's and Table II's values).

    Returns
    -------
    Trajectory
        The run; ``extra``: ``omega_ref``, ``omega``, ``i_ref``, ``i_q`` and ``sign_law``.
    """
    s = CascadeScenario(**options)
    dt = s.current.dt
    motor = _motor(s)
    ctl = _cascade(s.position, s.speed, s.current)
    encoder = Encoder(s.counts_per_rev, dt=s.speed.dt) if s.counts_per_rev else None
    ref, load = smooth_move(s.distance, s.move_time, s.move_start), s.load or _no_load
    n = round(s.t_end / dt)
    t = np.arange(n) * dt
    out = {k: np.empty(n) for k in _SIGNALS}
    theta_m, omega_m = 0.0, 0.0
    for k in range(n):
        tk = k * dt
        if encoder is None:
            theta_m, omega_m = motor.theta, motor.omega
        elif k % ctl.speed_every == 0:
            theta_m, omega_m = encoder.sample(motor.theta)
        theta_r = ref(tk)[0]
        u = ctl.step(theta_r, theta_m, omega_m, motor.current)
        for name, value in zip(_SIGNALS, _row(ctl, motor, theta_r, u)):
            out[name][k] = value
        motor.step(u, load(tk))
    return Trajectory(t, out["ref"], out["y"], out["u"], out["g"], {k: out[k] for k in _SIGNALS[4:]})
