"""DC position servo with chattering-free DTSM and switching integral, eqs. (7.30a-d).

The state is the error vector of (7.28), e = [theta_r - theta_m, omega_r - omega_m],
and the design is ``design_dtsm`` on A = [0 1; 0 -a_m], b = [0, -b_m] (7.31)::

    u_k   = u_s,k - u_I,k                                               (7.30a)
    u_s,k = -c_delta A_delta e_k - min{v_k, w_k} sgn(g_k),
            v_k = |g_k|/T, w_k = sigma + q |g_k|                       (7.30b)
    u_I,k = 0                      if min = w_k (reaching) or |e_2,k| > rho
            h g_k + u_I,k-1        otherwise (linear mode near the line) (7.30c)
    0 < rho, 0 < h < 1/T, h = alpha/T                                   (7.30d)

When min{v, w} = v the law is the deadbeat (6.14) and u_I is the compensator
(6.30b) with alpha = h T. The paper writes 0 < rho < 1; rho is a speed error in
rad/s, so any rho > 0 is accepted. Ties (v == w) count as the linear mode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from controllers.design import DTSMDesign

__all__ = ["PositionServo", "PositionServoParams"]


@dataclass(frozen=True, slots=True)
class PositionServoParams:
    """Parameters of (7.30); section VII.B uses sigma=10, q=0, rho=0.5, h=16.

    Raises
    ------
    ValueError
        If the design has not 2 states or a parameter is out of its range.
    """

    design: DTSMDesign  #: error-space design (7.28), (7.31)
    sigma: float = 10.0  #: reaching bound sigma > 0 [V]
    q: float = 0.0  #: proportional reaching gain q >= 0 [V / (V s)]
    rho: float = 0.5  #: speed-error threshold of the integral rho > 0 [rad/s]
    h: float = 16.0  #: integral gain 0 <= h < 1/T [1/s]
    u0: float = math.inf  #: output limit |u| <= U0 [V] (the converter's)

    def __post_init__(self) -> None:
        if self.design.order != 2:
            raise ValueError("the position servo needs a 2-state (error-space) design")
        if not self.sigma > 0.0:
            raise ValueError(f"sigma must be > 0, got {self.sigma!r}")
        if not self.q >= 0.0:
            raise ValueError(f"q must be >= 0, got {self.q!r}")
        if not self.rho > 0.0:
            raise ValueError(f"rho must be > 0 rad/s, got {self.rho!r}")
        if not (0.0 <= self.h < 1.0 / self.design.dt):
            raise ValueError(f"h must be in [0, 1/T) = [0, {1 / self.design.dt:g}), got {self.h!r}")
        if not self.u0 > 0.0:
            raise ValueError(f"u0 must be > 0, got {self.u0!r}")


@dataclass
class PositionServo:
    """The (7.30) law; ``step(e1, e2)`` returns u_k [V] and keeps g_k, u_I,k.

    Parameters
    ----------
    params : PositionServoParams
        The design and the law's parameters.
    """

    params: PositionServoParams
    g: float = field(default=0.0, init=False)  #: sliding variable g_k
    u_i: float = field(default=0.0, init=False)  #: switching integral u_I,k [V]
    linear: bool = field(default=False, init=False)  #: True when min{v, w} = v

    def __post_init__(self) -> None:
        d = self.params.design
        self._c1, self._c2 = d.c_delta
        self._k1, self._k2 = d.c_delta_A_delta
        self._inv_dt = 1.0 / d.dt

    def reset(self) -> None:
        """Restore the initial state."""
        self.g = 0.0
        self.u_i = 0.0
        self.linear = False

    def step(self, e1: float, e2: float) -> float:
        """One update of (7.30a-c).

        Parameters
        ----------
        e1 : float
            Position error theta_r - theta_m [rad].
        e2 : float
            Speed error omega_r - omega_m [rad/s].

        Returns
        -------
        float
            The voltage u_k [V], |u_k| <= U0.
        """
        p = self.params
        g = self._c1 * e1 + self._c2 * e2
        self.g = g
        u = -(self._k1 * e1 + self._k2 * e2)
        v = abs(g) * self._inv_dt
        w = p.sigma + p.q * abs(g)
        if v <= w:
            self.linear = True
            u -= g * self._inv_dt
            self.u_i = p.h * g + self.u_i if abs(e2) <= p.rho else 0.0
        else:
            self.linear = False
            u -= w if g > 0.0 else -w
            self.u_i = 0.0
        u -= self.u_i
        u0 = p.u0
        return u0 if u > u0 else (-u0 if u < -u0 else u)
