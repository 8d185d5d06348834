"""What (3.5) answers at a frequency: the model's response beside the measured one
(``rig.identify.frequency``).

(3.5) sampled with a zero-order hold, delayed by k samples, with the speed measured as the
backward difference of the position (``rig.identify.frequency``): from the ZOH solution used by
``simulate_positions`` (w_n+1 = alpha w_n + g b u_n, theta_n+1 = theta_n + g w_n + h b u_n,
alpha = e^(-a T), g = (1 - alpha)/a, h = (T - g)/a),

    W(z)/U(z) = b (h + (g^2 - h alpha) z^-1) z^-(k+1) / (T (1 - alpha z^-1)),

evaluated by ``scipy.signal.freqz``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["model_speed_response", "model_velocity_response", "speed_to_position"]


def model_speed_response(a: float, b: float, dt: float, delay: int, f: np.ndarray) -> np.ndarray:
    """The exact discrete response of (3.5) (a [1/s], b) from u to the speed by backward
    difference, with a delay of ``delay`` samples, at the frequencies ``f`` [Hz] (module doc).

    Parameters
    ----------
    a, b : float
        (3.5)'s a_m [1/s] and b_m.
    dt : float
        [s] the period.
    delay : int
        [samples].
    f : np.ndarray
        [Hz].

    Returns
    -------
    np.ndarray
        The complex response.
    """
    import scipy.signal

    alpha = math.exp(-a * dt)
    g = (1.0 - alpha) / a if a != 0.0 else dt
    h = (dt - g) / a if a != 0.0 else dt * dt / 2.0
    num = np.concatenate([np.zeros(delay + 1), [b * h / dt, b * (g * g - h * alpha) / dt]])
    _, response = scipy.signal.freqz(num, [1.0, -alpha], worN=np.asarray(f, dtype=float), fs=1.0 / dt)
    out: np.ndarray = response
    return out


def model_velocity_response(a: float, b: float, dt: float, delay: int, f: np.ndarray) -> np.ndarray:
    """(3.5)'s response from u to the speed sampled at the instants of the position (a drive's
    reported speed): b g z^-(k+1) / (1 - alpha z^-1) at ``f`` [Hz].

    Parameters
    ----------
    a, b : float
        (3.5)'s a_m [1/s] and b_m.
    dt : float
        [s] the period.
    delay : int
        [samples].
    f : np.ndarray
        [Hz].

    Returns
    -------
    np.ndarray
        The complex response.
    """
    import scipy.signal

    alpha = math.exp(-a * dt)
    g = (1.0 - alpha) / a if a != 0.0 else dt
    num = np.concatenate([np.zeros(delay + 1), [b * g]])
    _, response = scipy.signal.freqz(num, [1.0, -alpha], worN=np.asarray(f, dtype=float), fs=1.0 / dt)
    out: np.ndarray = response
    return out


def speed_to_position(f: np.ndarray, dt: float) -> np.ndarray:
    """T / (1 - z^-1) at ``f`` [Hz]: the position from the backward-difference speed.

    Parameters
    ----------
    f : np.ndarray
        [Hz].
    dt : float
        [s] the period T.

    Returns
    -------
    np.ndarray
        T / (1 - z^-1).
    """
    z_inv = np.exp(-2j * math.pi * np.asarray(f) * dt)
    out: np.ndarray = dt / (1.0 - z_inv)
    return out
