"""Metrics of a recorded response, with explicit definitions.

Every function takes plain sequences or numpy arrays of equal-spaced samples.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["chattering_count", "max_abs", "overshoot", "rise_time", "rms", "settling_time"]

Samples = Sequence[float] | np.ndarray


def rms(x: Samples) -> float:
    """Root mean square, sqrt(mean(x^2)); NaN for no samples."""
    a = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if a.size else math.nan


def max_abs(x: Samples) -> float:
    """Largest absolute value, max |x|; NaN for no samples."""
    a = np.asarray(x, dtype=float)
    return float(np.max(np.abs(a))) if a.size else math.nan


def chattering_count(u: Samples, *, tol: float = 0.0) -> int:
    """Number of sign alternations of the control increment du_k = u_k - u_k-1.

    Increments with |du_k| <= ``tol`` are treated as zero and skipped, so a
    rounding-level wiggle is not counted; an alternation is a pair of
    consecutive non-zero increments of opposite sign. A smooth (or monotone
    piecewise) control gives 0; a relay limit cycle gives about one per sample.
    """
    du = np.diff(np.asarray(u, dtype=float))
    signs = np.sign(du[np.abs(du) > tol])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def rise_time(e: Samples, *, dt: float, low: float = 0.05, high: float = 0.95) -> float:
    """Rise time of an error transition e(0) -> 0 [s], counted in samples times dt.

    The progress is p_k = 1 - e_k / e_0; the rise time is (k_high - k_low) dt with
    k_low, k_high the first samples where p reaches ``low`` and ``high``
    (5 % -> 95 % by default). NaN when e_0 = 0 or the transition never completes.
    """
    a = np.asarray(e, dtype=float)
    if a.size == 0 or a[0] == 0.0:
        return math.nan
    p = 1.0 - a / a[0]
    hit_low, hit_high = np.nonzero(p >= low)[0], np.nonzero(p >= high)[0]
    if hit_low.size == 0 or hit_high.size == 0:
        return math.nan
    return float(hit_high[0] - hit_low[0]) * dt


def settling_time(e: Samples, *, dt: float, band: float = 0.01) -> float:
    """Time [s] after which |e_k| stays within ``band`` |e_0| (1 % by default).

    It is (k + 1) dt for the last sample k outside the band; 0 when none is.
    NaN when the last sample is still outside (not settled within the record).
    """
    a = np.abs(np.asarray(e, dtype=float))
    if a.size == 0:
        return math.nan
    outside = np.nonzero(a > band * a[0])[0]
    if outside.size == 0:
        return 0.0
    if outside[-1] == a.size - 1:
        return math.nan
    return float(outside[-1] + 1) * dt


def overshoot(y: Samples, *, final: float, initial: float = 0.0) -> float:
    """Overshoot [%] of a step response from ``initial`` to ``final``: the largest
    excursion beyond ``final`` relative to the step size; 0 when none."""
    a = np.asarray(y, dtype=float)
    step = final - initial
    if step == 0.0 or a.size == 0:
        return math.nan
    beyond = (a - final) / step
    return float(max(0.0, np.max(beyond)) * 100.0)
