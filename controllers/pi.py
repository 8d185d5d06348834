"""Conventional discrete PI with anti-windup: the baseline of Table III of the drives paper.

    u_k = sat(k_p e_k + I_k),   I_{k+1} = I_k + k_i T e_k, clamped so the output stays
    inside the limits (conditional integration: the integrator never winds past
    the value that saturates the output).

Table III prints K_i values that read as per-sample increments (k_i T); pass
``ki = K_i / T`` to use them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["PI", "PIParams"]


@dataclass(frozen=True, slots=True)
class PIParams:
    """Gains and limits of the PI.

    Raises
    ------
    ValueError
        If dt is not > 0, a gain not finite (ki < 0), or u_min not below u_max.
    """

    kp: float  #: proportional gain [unit of u / unit of e]
    ki: float  #: integral gain [unit of u / (unit of e * s)]
    dt: float  #: sample period T [s]
    u_max: float = math.inf  #: upper output limit [unit of u]
    u_min: float = -math.inf  #: lower output limit [unit of u]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0.0):
            raise ValueError(f"dt must be > 0 s, got {self.dt!r}")
        if not (math.isfinite(self.kp) and math.isfinite(self.ki) and self.ki >= 0.0):
            raise ValueError(f"kp must be finite and ki finite >= 0, got {self.kp!r}, {self.ki!r}")
        if not self.u_min < self.u_max:
            raise ValueError(f"u_min must be < u_max, got {self.u_min!r} >= {self.u_max!r}")


@dataclass
class PI:
    """PI controller; ``step(e)`` returns u_k.

    Parameters
    ----------
    params : PIParams
        Gains, period and limits.
    """

    params: PIParams
    integral: float = field(default=0.0, init=False)  #: integrator state I_k [unit of u]

    def __post_init__(self) -> None:
        p = self.params
        self._kp = p.kp
        self._ki_dt = p.ki * p.dt
        self._hi = p.u_max
        self._lo = p.u_min

    def reset(self) -> None:
        """Restore the initial state."""
        self.integral = 0.0

    def step(self, e: float) -> float:
        """One update.

        Parameters
        ----------
        e : float
            The error e_k [unit of e].

        Returns
        -------
        float
            The control u_k [unit of u], within [u_min, u_max].
        """
        p_term = self._kp * e
        u = p_term + self.integral
        hi, lo = self._hi, self._lo
        u = hi if u > hi else (lo if u < lo else u)
        # Anti-windup: integrate, then keep the integrator inside the band that
        # leaves the next output unsaturated for the current proportional term.
        i = self.integral + self._ki_dt * e
        i_hi, i_lo = hi - p_term, lo - p_term
        if i > i_hi and i > self.integral:
            i = max(self.integral, i_hi)
        elif i < i_lo and i < self.integral:
            i = min(self.integral, i_lo)
        self.integral = i
        return u
