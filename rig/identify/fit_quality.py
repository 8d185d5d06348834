"""How well an identified model fits, and the encoder's count it is judged against.

The fit percentage is on held-out data (the last ``holdout`` of the record, not used for the
estimate): 100 (1 - ||y - y_hat|| / ||y - mean(y)||) with y the speed by central differences of
the measured position and y_hat the model's (``held_out_fit``). The figure alone misleads where
the speed varies little against the encoder's count (``quantum``): a chirp or multisine of small
amplitude, a slow shaft. Central differences of positions quantised to q [rad] carry a noise of
RMS q / (T sqrt(24)) (two independent errors uniform over q, variance q^2/12 each, over 2T: B.
Widrow, I. Kollar, "Quantization Noise", Cambridge 2008, ch. 4), whatever the model;
``residual_rms`` and ``quantisation_rms`` are both given, and a low fit is only the model's fault
where the residual is well above that floor (``rig.identify.model_file.checks``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["held_out_fit", "quantum"]


def quantum(theta: np.ndarray) -> float:
    """The encoder's count [rad]: the greatest q of which every step of the position is a whole
    multiple (a fast shaft may never move by one count in a period: steps of 2 and 3 counts give
    one), the smallest step where they have no such common measure up to an eighth of it.

    Parameters
    ----------
    theta : np.ndarray
        The position [rad].

    Returns
    -------
    float
        [rad] one count.
    """
    steps = np.abs(np.diff(theta))
    steps = steps[steps > 1e-12]
    if not len(steps):
        return 2.0 * math.pi / 4096
    smallest = float(np.min(steps))
    ratios = steps / smallest
    for m in range(1, 9):
        if np.all(np.abs(ratios * m - np.rint(ratios * m)) < 1e-6):
            return smallest / m
    return smallest


def held_out_fit(theta: np.ndarray, w_model: np.ndarray, n_fit: int, dt: float) -> tuple[float, float, float]:
    """(fit [%], residual RMS [rad/s], quantisation noise RMS [rad/s]) of the model's speed
    ``w_model`` against the central differences of the measured positions ``theta`` [rad]
    from sample ``n_fit`` on (module doc).

    Parameters
    ----------
    theta : np.ndarray
        The measured position [rad].
    w_model : np.ndarray
        [rad/s] the model's speed.
    n_fit : int
        The first held-out sample.
    dt : float
        [s] the period.

    Returns
    -------
    tuple[float, float, float]
        (fit [%], residual RMS [rad/s], quantisation RMS [rad/s]).
    """
    w_meas = np.gradient(theta, dt)
    yv, yh = w_meas[n_fit + 1 : -1], w_model[n_fit + 1 : -1]
    denom = float(np.linalg.norm(yv - yv.mean()))
    residual = float(np.linalg.norm(yv - yh))
    fit = 100.0 * (1.0 - residual / denom) if denom > 0 else math.nan
    rms = residual / math.sqrt(len(yv)) if len(yv) else math.nan
    return fit, rms, quantum(theta) / (dt * math.sqrt(24.0))
