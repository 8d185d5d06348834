"""A step's response (``rig.report.metrics``' definitions): rise time, settling time and overshoot of
equal-spaced samples."""

from __future__ import annotations

import math

import numpy as np

from rig.report.metrics import Samples

__all__ = ["overshoot", "rise_time", "settling_time"]


def rise_time(e: Samples, *, dt: float, low: float = 0.05, high: float = 0.95) -> float:
    """Rise time of an error transition e(0) -> 0 [s], counted in samples times dt.

    The progress is p_k = 1 - e_k / e_0; the rise time is (k_high - k_low) dt with
    k_low, k_high the first samples where p reaches ``low`` and ``high``
    (5 % -> 95 % by default). NaN when e_0 = 0 or the transition never completes.

    Parameters
    ----------
    e : Samples
        The error.
    dt : float
        [s] the period.
    low, high : float, optional
        The progress's bounds.

    Returns
    -------
    float
        [s].
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

    Parameters
    ----------
    e : Samples
        The error.
    dt : float
        [s] the period.
    band : float, optional
        Of |e_0|.

    Returns
    -------
    float
        [s].
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
    excursion beyond ``final`` relative to the step size; 0 when none.

    Parameters
    ----------
    y : Samples
        The response.
    final : float
        Its final value.
    initial : float, optional
        Its initial value.

    Returns
    -------
    float
        [%].
    """
    a = np.asarray(y, dtype=float)
    step = final - initial
    if step == 0.0 or a.size == 0:
        return math.nan
    beyond = (a - final) / step
    return float(max(0.0, np.max(beyond)) * 100.0)
