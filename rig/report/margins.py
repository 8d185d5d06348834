"""Stability margins of a discrete open loop L(z) and its closed loop's bandwidth."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["LoopMargins", "loop_margins"]


@dataclass(frozen=True)
class LoopMargins:
    """Stability margins of a discrete open loop and the closed loop's bandwidth."""

    gain_margin_db: float  #: -20 log10 |L| where the phase is -180 deg (inf: never)
    phase_margin_deg: float  #: 180 deg + phase of L where |L| = 1 (inf: never)
    bandwidth_ratio: float  #: f / f_s where |L/(1+L)| first falls to 1/sqrt(2)


def _crossing(x: np.ndarray, y: np.ndarray, level: float) -> list[float]:
    """x where y crosses ``level`` (linear interpolation between grid points)."""
    d = y - level
    idx = np.nonzero(np.signbit(d[:-1]) != np.signbit(d[1:]))[0]
    return [float(x[i] - d[i] * (x[i + 1] - x[i]) / (d[i + 1] - d[i])) for i in idx]


def loop_margins(loop: Callable[[complex], complex], *, points: int = 20001) -> LoopMargins:
    """Gain and phase margin of the open loop L(z) and the closed-loop bandwidth.

    L is evaluated on z = e^{j Omega} for Omega in (0, pi] and, because a
    complex-coefficient loop is not conjugate-symmetric, also in [-pi, 0); the
    worse side is reported. The phase is unwrapped from Omega -> 0, so a
    crossing of -180 deg (of +180 deg on the negative side) is a phase crossover.
    The bandwidth is the first |Omega| where |L/(1+L)| = 1/sqrt(2), divided by 2 pi.

    Parameters
    ----------
    loop : Callable[[complex], complex]
        L(z).
    points : int, optional
        Omega's grid.

    Returns
    -------
    LoopMargins
        The margins and the bandwidth.
    """
    omega = np.linspace(1e-6, math.pi, points)
    gm, pm, bw = math.inf, math.inf, math.inf
    for sign in (1.0, -1.0):
        lz = np.array([loop(complex(math.cos(w), sign * math.sin(w))) for w in omega])
        mag = np.abs(lz)
        phase = np.degrees(np.unwrap(np.angle(lz)))
        for w in _crossing(omega, sign * phase, -180.0):
            gm = min(gm, -20.0 * math.log10(abs(loop(complex(math.cos(w), sign * math.sin(w))))))
        for w in _crossing(omega, mag, 1.0):
            pm = min(pm, 180.0 + sign * float(np.interp(w, omega, phase)))
        closed = np.abs(lz / (1.0 + lz))
        below = _crossing(omega, closed, 1.0 / math.sqrt(2.0))
        if below:
            bw = min(bw, below[0] / (2.0 * math.pi))
    return LoopMargins(gm, pm, bw)
