"""Speed control of (3.5) under a matched disturbance (Fig. 9) simulated, with the compensators
(6.30b) and (6.35).

Lock-step and deterministic: one controller step, then exact plant steps per sample
(``rig.papers.scenarios``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from controllers.compensators import FirstOrderCompensator, SecondOrderCompensator
from controllers.design import design_dtsm
from controllers.dtsm import DTSM, DTSMParams
from plant_emulator.dc_motor import ReducedDCMotor
from rig.laws import drives_paper as drives
from rig.papers.trajectory import Trajectory

__all__ = ["SpeedScenario", "speed_loop_run"]


@dataclass(frozen=True)
class SpeedScenario:
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
    """

    compensator: str = "none"  #: "none", "first" or "second"
    alpha: float = 1.0  #: the first's gain
    a_m: float = drives.A_M  #: [1/s] of the plant (3.5)
    b_m: float = drives.B_M  #: [rad/(V s^2)] of the plant (3.5)
    dt: float = 1e-3  #: [s] the period
    t_end: float = 4.0  #: [s] the run's length
    disturbance: Callable[[float], float] | None = None  #: f(t) [V] (None: 5 h(t-2) sin(5t))
    substeps: int = 20  #: exact sub-steps per sample
    held_disturbance: bool = False  #: f(kT) held over each sample
    law: Literal["deadbeat", "bounded"] = "deadbeat"  #: "deadbeat" (6.14) or "bounded" (6.15a)
    sigma: float = math.inf  #: [V] the reaching bound
    speed_step: float = 0.0  #: [rad/s] the reference


def _compensator(name: str, alpha: float, dt: float) -> FirstOrderCompensator | SecondOrderCompensator | None:
    """The compensator called ``name``: none, (6.30b) of gain ``alpha``, or (6.35)."""
    if name == "none":
        return None
    if name == "first":
        return FirstOrderCompensator(alpha=alpha, dt=dt)
    if name == "second":
        return SecondOrderCompensator(dt=dt)
    raise ValueError(f"compensator must be 'none', 'first' or 'second', got {name!r}")


def _law(s: SpeedScenario) -> DTSM:
    """The DTSM of ``s`` on the first-order design of (3.5), with its compensator."""
    design = design_dtsm(A=[[-s.a_m]], b=[s.b_m], dt=s.dt, lam=-1.0)
    comp = _compensator(s.compensator, s.alpha, s.dt)
    compensate: Literal["always", "linear"] = "linear" if s.law == "bounded" else "always"
    return DTSM(DTSMParams(design=design, law=s.law, sigma=s.sigma, compensate=compensate), compensator=comp)


def _default_disturbance(t: float) -> float:
    """f(t) = 5 h(t-2) sin(5t) [V] of Fig. 9."""
    return 5.0 * math.sin(5.0 * t) if t >= 2.0 else 0.0


def speed_loop_run(**options: Any) -> Trajectory:
    """Simulate the speed loop of Fig. 9 (``SpeedScenario``) for its ``t_end``.

    Parameters
    ----------
    **options : Any
        ``SpeedScenario``'s fields by name (not given: its defaults).

    Returns
    -------
    Trajectory
        The run: y = omega, and in ``extra["d"]`` the disturbance d_k the step saw (nan unless
        ``held_disturbance``).

    Raises
    ------
    ValueError
        If the compensator or the law is unknown.
    """
    s = SpeedScenario(**options)
    f = s.disturbance or _default_disturbance
    ctl = _law(s)
    sub = 1 if s.held_disturbance else s.substeps
    motor = ReducedDCMotor(a_m=s.a_m, b_m=s.b_m, dt=s.dt / sub)
    n = round(s.t_end / s.dt)
    t = np.arange(n) * s.dt
    y, u_out, g, d = (np.empty(n) for _ in range(4))
    for k in range(n):
        u = ctl.step(motor.omega - s.speed_step)
        y[k], u_out[k], g[k] = motor.omega, u, ctl.g
        if s.held_disturbance:
            d[k] = f(k * s.dt)
            motor.step(u, f=d[k])
        else:
            d[k] = math.nan
            for i in range(sub):
                motor.step(u, f=f((k + (i + 0.5) / sub) * s.dt))
    return Trajectory(t, np.full(n, s.speed_step), y, u_out, g, {"d": d})
