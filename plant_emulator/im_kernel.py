"""The induction motor's inner loop, compiled: FOC steps of the PI current loops and RK4 of the
machine, over one piece of physics (``ImAxis.advance``; the model is in its module docstring).

One implementation, written in the subset of Python that numba compiles (floats, complex,
math and cmath, numpy arrays): with numba installed it runs as machine code (``njit``,
cached on disk), without it as this same Python. State and constants travel in float arrays
so nothing is boxed per step:

- ``x`` = [Re i_s, Im i_s, Re psi_r, Im psi_r, omega_m, theta_m, theta_e, int_d, int_q]
  (stationary frame [A], [Wb]; [rad/s], [rad], the FOC angle [rad], the PI integrals [V]);
- ``k`` = the constants the index constants ``R_SIGMA`` ... ``LM_TR`` (``ImAxis._constants``).

Per FOC step of ``hs`` [s]: slip (4.5) with psi_r = L_m i_ds* (4.7), PI current loops of
Table III with conditional integration and the |u| <= U_DC/sqrt(3) limit, the voltage held
in the stationary frame over 4 RK4 sub-steps of (4.1)-(4.3) with the mechanics (4.2), and the
Coulomb friction of ``plant_emulator.friction`` chosen at the step's start and held with T_L.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from plant_emulator import friction

__all__ = ["JIT", "N", "foc_periods"]

(
    R_SIGMA,  # R_sigma = R_s + R_r L_m^2/L_r^2 [ohm]
    SIGMA_LS,  # sigma L_s [H]
    LM_LR,  # L_m/L_r
    T_R,  # T_r = L_r/R_r [s]
    PP,  # pole pairs
    B,  # viscous friction [N m s/rad]
    J,  # inertia [kg m^2]
    KP,  # current PI: proportional [V/A]
    KI,  # current PI: integral per FOC step [V/A]
    I_DS,  # i_ds* [A]
    U_MAX,  # U_DC/sqrt(3) [V]
    I_LIMIT,  # |i_qs*| limit [A]
    SLIP,  # slip per A of i_qs*: 1/(T_r i_ds*) [rad/s per A]
    FOC_DT,  # the FOC period [s]
    LM_TR,  # L_m/T_r [H/s]
    COULOMB,  # Coulomb friction T_c [N m] (``plant_emulator.friction``)
    N,
) = range(17)


def _jit(fn: Callable[..., Any]) -> tuple[Callable[..., Any], bool]:
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is a dependency; the same code runs as Python
        return fn, False
    return numba.njit(cache=True, fastmath=False)(fn), True


_held, _ = _jit(friction.held)
_settle, _ = _jit(friction.settle)


def _current_loops_py(  # noqa: PLR0917 - numba compiles positional parameters only
    i_s: complex, w: float, theta_e: float, int_d: float, int_q: float, i_q: float, k: np.ndarray
) -> tuple[complex, float, float, float]:
    """One FOC step's PI current loops (Table III, conditional integration, |u| <= U_DC/sqrt(3))
    and slip (4.5): (the stationary-frame voltage [V], the next FOC angle [rad], the integrals [V])."""
    i_dq = i_s * cmath.exp(complex(0.0, -theta_e))
    e_d, e_q = k[I_DS] - i_dq.real, i_q - i_dq.imag
    u_d = k[KP] * e_d + int_d + k[KI] * e_d
    u_q = k[KP] * e_q + int_q + k[KI] * e_q
    mag = math.hypot(u_d, u_q)
    if mag <= k[U_MAX]:  # conditional integration (anti-windup)
        int_d += k[KI] * e_d
        int_q += k[KI] * e_q
    else:
        u_d, u_q = u_d * k[U_MAX] / mag, u_q * k[U_MAX] / mag
    omega_e = k[PP] * w + k[SLIP] * i_q  # (4.5) with psi_r = L_m i_ds* (4.7)
    u = complex(u_d, u_q) * cmath.exp(complex(0.0, theta_e))
    theta_e += omega_e * k[FOC_DT]
    theta_e -= 2.0 * math.pi * round(theta_e / (2.0 * math.pi))  # into [-pi, pi] (remainder)
    return u, theta_e, int_d, int_q


_current_loops, _ = _jit(_current_loops_py)


def _foc_periods(  # noqa: PLR0917 - numba compiles positional parameters only
    x: np.ndarray, k: np.ndarray, i_q_ref: float, enabled: bool, hs: float, loads: np.ndarray
) -> None:
    """Advance ``x`` by ``len(loads)`` FOC steps of ``hs`` [s], T_L = ``loads`` [N m] in each."""
    i_s, psi = complex(x[0], x[1]), complex(x[2], x[3])
    w, theta, theta_e, int_d, int_q = x[4], x[5], x[6], x[7], x[8]
    lm_tr = k[LM_TR]
    torque_k = 1.5 * k[PP] * k[LM_LR]
    h = hs / 4.0
    limit = k[I_LIMIT]
    i_q = max(-limit, min(limit, i_q_ref))
    for n in range(loads.shape[0]):
        t_load = loads[n]
        u = 0j
        if enabled:
            u, theta_e, int_d, int_q = _current_loops(i_s, w, theta_e, int_d, int_q, i_q, k)
        else:
            i_s = 0j  # inverter off: no stator current
        coulomb = k[COULOMB]
        t_friction, stuck, theta_0 = 0.0, False, theta
        if coulomb > 0.0:  # held over the FOC step with T_L (``plant_emulator.friction``)
            drive = torque_k * (psi.real * i_s.imag - psi.imag * i_s.real) - t_load
            t_friction, stuck = _held(w, drive, coulomb)
            t_load += t_friction
        for _ in range(4):  # RK4 with u held
            i1, p1, w1 = i_s, psi, w
            c1 = complex(1.0 / k[T_R], -k[PP] * w1)
            d1 = (u - k[R_SIGMA] * i1 + k[LM_LR] * c1 * p1) / k[SIGMA_LS]
            q1 = lm_tr * i1 - c1 * p1
            a1 = (torque_k * (p1.real * i1.imag - p1.imag * i1.real) - k[B] * w1 - t_load) / k[J]
            i2, p2, w2 = i_s + h / 2 * d1, psi + h / 2 * q1, w + h / 2 * a1
            c2 = complex(1.0 / k[T_R], -k[PP] * w2)
            d2 = (u - k[R_SIGMA] * i2 + k[LM_LR] * c2 * p2) / k[SIGMA_LS]
            q2 = lm_tr * i2 - c2 * p2
            a2 = (torque_k * (p2.real * i2.imag - p2.imag * i2.real) - k[B] * w2 - t_load) / k[J]
            i3, p3, w3 = i_s + h / 2 * d2, psi + h / 2 * q2, w + h / 2 * a2
            c3 = complex(1.0 / k[T_R], -k[PP] * w3)
            d3 = (u - k[R_SIGMA] * i3 + k[LM_LR] * c3 * p3) / k[SIGMA_LS]
            q3 = lm_tr * i3 - c3 * p3
            a3 = (torque_k * (p3.real * i3.imag - p3.imag * i3.real) - k[B] * w3 - t_load) / k[J]
            i4, p4, w4 = i_s + h * d3, psi + h * q3, w + h * a3
            c4 = complex(1.0 / k[T_R], -k[PP] * w4)
            d4 = (u - k[R_SIGMA] * i4 + k[LM_LR] * c4 * p4) / k[SIGMA_LS]
            q4 = lm_tr * i4 - c4 * p4
            a4 = (torque_k * (p4.real * i4.imag - p4.imag * i4.real) - k[B] * w4 - t_load) / k[J]
            i_s = i_s + h / 6 * (d1 + 2 * d2 + 2 * d3 + d4)
            psi = psi + h / 6 * (q1 + 2 * q2 + 2 * q3 + q4)
            theta += h / 6 * (w + 2 * w2 + 2 * w3 + w4)
            w = w + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        if stuck:
            w, theta = 0.0, theta_0
        elif coulomb > 0.0:
            w = _settle(w, t_friction)
    x[0], x[1], x[2], x[3] = i_s.real, i_s.imag, psi.real, psi.imag
    x[4], x[5], x[6], x[7], x[8] = w, theta, theta_e, int_d, int_q


foc_periods, JIT = _jit(_foc_periods)
