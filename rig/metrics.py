"""Metrics of a recorded response, with explicit definitions.

Every function takes plain sequences or numpy arrays of equal-spaced samples.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["chattering_count", "max_abs", "rms"]

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
