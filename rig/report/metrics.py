"""Metrics of a recorded response, with explicit definitions: its size (``rms``, ``max_abs``) and
its chattering (sign changes of the command's increments, against the measurements' resolution).
A step's response is ``rig.report.step_response``'s, a loop's margins ``rig.report.margins``'.

Every function takes plain sequences or numpy arrays of equal-spaced samples.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = [
    "ROUNDING",
    "beyond",
    "chattering_amplitude",
    "chattering_count",
    "common_quantum",
    "count_threshold",
    "feedback_resolution",
    "max_abs",
    "measured_quantum",
    "not_measurable",
    "rms",
    "sign_law_share",
    "steady_chattering",
]

Samples = Sequence[float] | np.ndarray

#: An increment at or below this [unit of u] is rounding, never chattering.
ROUNDING = 1e-9
#: two steps whose ratio is a whole number within this (relative) have a common quantum; one
#: below this part of the larger step is none (continuous values)
QUANTUM_TOLERANCE = 1e-6


def rms(x: Samples) -> float:
    """Root mean square, sqrt(mean(x^2)); NaN for no samples.

    Parameters
    ----------
    x : Samples
        The samples.

    Returns
    -------
    float
        sqrt(mean(x^2)).
    """
    a = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if a.size else math.nan


def max_abs(x: Samples) -> float:
    """Largest absolute value, max |x|; NaN for no samples.

    Parameters
    ----------
    x : Samples
        The samples.

    Returns
    -------
    float
        max |x|.
    """
    a = np.asarray(x, dtype=float)
    return float(np.max(np.abs(a))) if a.size else math.nan


def beyond(threshold: float) -> float:
    """The increment [unit of u] an alternation must exceed: ``threshold`` widened by its rounding
    (``QUANTUM_TOLERANCE``: a one-count limit cycle's increments equal the threshold, and one of
    them a rounding above it is still one count), and ``ROUNDING`` at least.

    Parameters
    ----------
    threshold : float
        [unit of u].

    Returns
    -------
    float
        [unit of u].
    """
    return max(threshold * (1.0 + QUANTUM_TOLERANCE), ROUNDING)


def chattering_count(u: Samples, *, threshold: float = 0.0) -> int:
    """Chattering as engineers mean it: sign alternations of the command increment
    du_k = u_k - u_k-1 that are larger than the measurement can explain.

    Only increments with |du_k| > ``threshold`` (``beyond``: within rounding) take part; an
    alternation is a pair of consecutive such increments of opposite sign. ``threshold`` [unit of
    u] is the change of u one step of the feedback's resolution can cause through the law
    (``count_threshold``), so a
    one-count limit cycle of a quantised measurement is not counted and a relay's 2 sigma
    switching is; for exact measurements (a pure simulation) it is 0 and ``ROUNDING`` (1e-9) is
    used so rounding is not counted. A smooth or monotone control gives 0; a relay limit cycle
    about one per sample.

    Parameters
    ----------
    u : Samples
        The command.
    threshold : float, optional
        [unit of u] the increment one count explains.

    Returns
    -------
    int
        The alternations.
    """
    tol = beyond(threshold)
    du = np.diff(np.asarray(u, dtype=float))
    signs = np.sign(du[np.abs(du) > tol])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def chattering_amplitude(u: Samples) -> float:
    """RMS of the command increment du_k = u_k - u_k-1 [unit of u] over the samples given
    (the steady state); NaN for fewer than two samples.

    Parameters
    ----------
    u : Samples
        The command.

    Returns
    -------
    float
        [unit of u].
    """
    a = np.asarray(u, dtype=float)
    return rms(np.diff(a)) if a.size > 1 else math.nan


def common_quantum(a: float, b: float) -> float:
    """The largest q of which both steps ``a``, ``b`` > 0 are whole multiples: Euclid's algorithm on
    floats, a remainder within ``QUANTUM_TOLERANCE`` of the larger step (of 0 or of the divisor)
    being none, and q then taken as the larger step over its whole multiple of q (rounding does not
    accumulate); 0 where q would be within that tolerance (no quantum: continuous values).

    Parameters
    ----------
    a, b : float
        The steps, > 0.

    Returns
    -------
    float
        q (0: none).
    """
    top = max(a, b)
    a, b = top, min(a, b)
    tol = QUANTUM_TOLERANCE * top
    while b > tol:
        r = math.fmod(a, b)
        if r <= tol or b - r <= tol:
            return top / round(top / b)
        a, b = b, r
    return 0.0


def feedback_resolution(x: Samples) -> float:
    """The resolution of a recorded measurement [unit of x]: the largest quantum of which every
    step |x_k - x_k-1| between consecutive samples is a whole multiple (``common_quantum``); 0 when
    it never changed or has no quantum (NaN samples are skipped). A drive's 0x606C in increments/s
    steps by whole increments/s however fast the speed changes, a speed differenced from the
    encoder over T by whole counts over T.

    Parameters
    ----------
    x : Samples
        The samples.

    Returns
    -------
    float
        [unit of x] (0: none).
    """
    d = np.abs(np.diff(np.asarray(x, dtype=float)))
    d = d[d > 0.0]
    q = float(d[0]) if d.size else 0.0
    for step in d[1:]:
        q = common_quantum(q, float(step))
        if not q:
            break
    return q


def measured_quantum(declared: float, measured: float) -> float:
    """The quantum of a measurement: the one its samples show (``feedback_resolution``) where they
    have one (> 0), never below what the device or encoder ``declared``; else the declared one
    (0: not known).

    Parameters
    ----------
    declared : float
        What the device declares (0: not known).
    measured : float
        What the samples show (0: none).

    Returns
    -------
    float
        The quantum.
    """
    return max(declared, measured) if measured > 0.0 else declared


def count_threshold(
    sensitivity: tuple[float, float], *, position_quantum: float, velocity_quantum: float
) -> float:
    """The change of a law's command that one step of its feedback's resolution can cause
    [unit of u].

    ``sensitivity`` is (|du/dtheta|, |du/domega|) of the law's continuous part (its gradient in
    linear operation, ``Law.sensitivity``); ``position_quantum`` [rad] and ``velocity_quantum``
    [rad/s] are the resolution of the position and the speed the law read in that run
    (``measured_quantum``). Both 0 for exact measurements.

        threshold = |du/dtheta| q_theta + |du/domega| q_omega

    Parameters
    ----------
    sensitivity : tuple[float, float]
        The law's command per unit of (position, velocity).
    position_quantum : float
        [rad].
    velocity_quantum : float
        [rad/s].

    Returns
    -------
    float
        [unit of u].
    """
    return sensitivity[0] * position_quantum + sensitivity[1] * velocity_quantum


def not_measurable(threshold: float, command_range: float) -> str | None:
    """Why a chattering count cannot be measured (None: it can): where the ``threshold`` is at
    least the command's whole ``command_range`` [both unit of u] no increment can exceed it, and a
    count of 0 would say nothing.

    Parameters
    ----------
    threshold : float
        [unit of u].
    command_range : float
        [unit of u].

    Returns
    -------
    str | None
        Why, or None.
    """
    if threshold >= command_range:
        return (
            f"not measurable: one step of the feedback's resolution moves the command by {threshold:.3g}, "
            f"at least its whole range ({command_range:.3g}), so no increment can exceed it"
        )
    return None


def sign_law_share(sign_law: Samples) -> float:
    """The share of cycles a sliding-mode law spent outside its linear region: the mean of its
    per-cycle ``sign_law`` flags (1: the sign term of (6.8) or (7.30b)'s sigma branch, or a bound,
    made the command); NaN for no samples. It needs no threshold.

    Parameters
    ----------
    sign_law : Samples
        The per-cycle flags.

    Returns
    -------
    float
        The share, 0-1.
    """
    a = np.asarray(sign_law, dtype=float)
    return float(np.mean(a != 0.0)) if a.size else math.nan


def steady_chattering(
    u: Samples, sign_law: Samples | None, *, threshold: float, command_range: float = math.inf
) -> dict[str, Any]:
    """The chattering figures of a steady-state window, as a run's summary has them:
    ``chattering_count`` (NaN where ``not_measurable``, ``chattering_note`` saying why),
    ``chattering_amplitude`` and ``sign_law_share`` (NaN without ``sign_law`` flags: not a
    sliding-mode law).

    Parameters
    ----------
    u : Samples
        The command in the window.
    sign_law : Samples | None
        The law's flags (None: none).
    threshold : float
        [unit of u].
    command_range : float, optional
        [unit of u].

    Returns
    -------
    dict[str, Any]
        The figures.
    """
    note = not_measurable(threshold, command_range)
    return {
        "chattering_count": math.nan if note else chattering_count(u, threshold=threshold),
        "chattering_note": note,
        "chattering_amplitude": chattering_amplitude(u),
        "sign_law_share": math.nan if sign_law is None else sign_law_share(sign_law),
    }
