"""Karnopp's stick-slip friction as ``rig.identify.friction`` fits it: the positions of
dw/dt = -a w + b u - c sign(w) + d solved exactly over each period (``stick_slip_positions``), and
the sign of the speed taken from a measured position (``speed_signs``) with its reversals (D.
Karnopp, "Computer simulation of stick-slip friction in mechanical dynamic systems", J. Dyn. Sys.,
Meas., Control 107 (1985) 100-103).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rig.identify.estimate import _shift
from rig.identify.fit_quality import quantum

__all__ = ["count_reversals", "reverses", "sign_changes", "speed_signs", "stick_slip_positions"]


def speed_signs(theta: np.ndarray, counts: float) -> np.ndarray:
    """s_k: the sign of theta_k+1 - theta_k-1, 0 where that is under ``counts`` [rad] (one
    encoder count) or at the ends.

    Parameters
    ----------
    theta : np.ndarray
        The position [rad].
    counts : float
        [rad] one encoder count.

    Returns
    -------
    np.ndarray
        s_k.
    """
    s = np.zeros(len(theta))
    diff = theta[2:] - theta[:-2]
    s[1:-1] = np.where(np.abs(diff) < counts, 0.0, np.sign(diff))
    return s


def _slip(w: float, v: float, a: float, t: float) -> tuple[float, float]:
    """(angle gained, speed) after ``t`` [s] of dw/dt = -a w + v from ``w``."""
    if a == 0.0:
        return w * t + v * t * t / 2.0, w + v * t
    w_inf = v / a
    decay = math.exp(-a * t)
    return w_inf * t + (w - w_inf) * (1.0 - decay) / a, w_inf + (w - w_inf) * decay


def _positions(  # noqa: PLR0917 - numba compiles it: positional arguments
    bu: np.ndarray, a: float, dt: float, c: float, theta0: float, w0: float
) -> np.ndarray:
    """The loop of ``stick_slip_positions`` in the subset of Python numba compiles (floats, arrays)."""
    out = np.empty(len(bu))
    theta, w = theta0, w0
    for n in range(len(bu)):
        out[n] = theta
        drive, left = bu[n], dt
        while left > 0.0:
            if w == 0.0:
                if -c <= drive <= c:
                    break  # stuck: the friction balances the drive
                f = c if drive > 0.0 else -c  # breaks away
            else:
                f = c if w > 0.0 else -c
            v = drive - f
            gained, w_end = _slip(w, v, a, left)
            if w_end * f >= 0.0:  # still moving the same way (or just at rest) at the period's end
                theta += gained
                w = w_end
                break
            # w reaches 0 within the period, at t_stop: -a w + v < 0 there, so it stops
            if a == 0.0:
                t_stop = -w / v
            else:
                t_stop = math.log((w - v / a) / (-v / a)) / a
            gained, _ = _slip(w, v, a, t_stop)
            theta += gained
            w = 0.0
            left -= t_stop
    return out


_KERNEL: list[Any] = []


def _kernel() -> Any:
    """``_positions`` compiled by numba (a dependency: the emulator's kernel uses it), on first
    use and cached on disk; the same Python without numba."""
    if not _KERNEL:
        try:
            import numba
        except ImportError:  # pragma: no cover - numba is a dependency
            _KERNEL.append(_positions)
        else:
            global _slip  # noqa: PLW0603 - the kernel calls the compiled helper
            _slip = numba.njit(cache=True)(_slip)
            _KERNEL.append(numba.njit(cache=True)(_positions))
    return _KERNEL[0]


def stick_slip_positions(p: np.ndarray, u: np.ndarray, dt: float, k: int) -> np.ndarray:
    """Positions of the model with p = (a, b, c, d, theta_0, w_0, delta): the exact solution
    over each period with the drive b u + d held (ZOH) and Coulomb friction with stiction
    (Karnopp's model, solved exactly in continuous time): -c sign(w) while moving; a speed that
    reaches zero within a period stops there, and at rest the shaft stays stuck while the drive
    is within +-c, else breaks away. u is delayed by k + delta samples:
    (1 - delta) u_n-k + delta u_n-k-1 over period n (a drive's current loop takes part of a
    period to follow a torque step).

    Parameters
    ----------
    p : np.ndarray
        (a [1/s], b, c [rad/s^2], d [rad/s^2], theta_0 [rad], w_0 [rad/s], delta [samples]).
    u : np.ndarray
        The command per sample [N m or V].
    dt : float
        [s] the period.
    k : int
        [samples] the whole delay.

    Returns
    -------
    np.ndarray
        The positions [rad].
    """
    a, b, c, d, theta0, w0, delta = (float(x) for x in p)
    held = (1.0 - delta) * _shift(u, k) + delta * _shift(u, k + 1)
    out: np.ndarray = _kernel()(b * held + d, a, dt, abs(c), theta0, w0)
    return out


def sign_changes(s: np.ndarray) -> int:
    """How often the signs ``s`` change, their zeros (at rest) left out.

    Parameters
    ----------
    s : np.ndarray
        Signs (``speed_signs``).

    Returns
    -------
    int
        Sign changes.
    """
    moving = s[s != 0.0]
    return int(np.count_nonzero(np.diff(moving))) if len(moving) else 0


def count_reversals(theta: np.ndarray) -> int:
    """How often the speed (from the position, ``speed_signs``) changes sign in the record.

    Parameters
    ----------
    theta : np.ndarray
        The position [rad].

    Returns
    -------
    int
        Sign changes.
    """
    return sign_changes(speed_signs(theta, quantum(theta)))


def reverses(theta: np.ndarray) -> bool:
    """The speed (from the position, ``speed_signs``) changes sign in the record.

    Parameters
    ----------
    theta : np.ndarray
        The position [rad].

    Returns
    -------
    bool
        The speed changes sign.
    """
    return count_reversals(theta) > 0
