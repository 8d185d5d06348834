"""Integral DTSM for first-order plants, eqs. (6.20)-(6.21) of the drives paper.

The plant is delta(y_k) = a_delta y_k + b_delta u_k and the controller works on the
tracking error e_k = r_k - y_k, so delta(e_k) = a_delta e_k - b_delta u_k for a
constant reference; this is the sign convention under which the printed (6.21)
follows.

(6.20) as printed, g_{k+1} = g_k + b_delta (x_{k+1} - x_k) - T lambda_delta x_k,
lacks b_delta^-1 on its terms. The sliding variable used here is

    g_k = g_{k-1} + b_delta^-1 (e_k - e_{k-1} - T lambda_delta e_{k-1}),   (6.20)

and g_{k+1} = 0 gives the control

    u_k = T^-1 g_k + b_delta^-1 (a_delta - lambda_delta) e_k = T^-1 g_k + K_eq e_k.  (6.21)

The integrator starts at g_0 = 0 with e_{-1} taken so that the initial state lies
on the sliding line (Remark 4). On the line the error decays as
e_{k+1} = (1 + T lambda_delta) e_k; a constant matched disturbance moves g to a
constant and leaves no steady-state error. ``g_limit`` bounds the integrator
(the +-0.01 of "Int 1" in section VII.C).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from controllers.design import lambda_delta as to_lambda_delta
from controllers.discretize import delta_model

__all__ = ["IDTSM", "IDTSMParams"]


@dataclass(frozen=True, slots=True)
class IDTSMParams:
    """Parameters of the integral DTSM of a first-order plant y' = a y + b u.

    Raises
    ------
    ValueError
        If dt is not > 0, lam not < 0, b zero or not finite, or g_limit or u0 not > 0.
    """

    a: float  #: continuous-time plant pole a [1/s] (a = -a_m for (3.5))
    b: float  #: continuous-time input gain b [unit of y / (s * unit of u)]
    dt: float  #: sample period T [s]
    lam: float  #: desired continuous-time eigenvalue lambda < 0 [1/s]
    g_limit: float = math.inf  #: bound on the integrator |g| [unit of u * s]
    u0: float = math.inf  #: output limit |u| <= U0 [unit of u]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0.0):
            raise ValueError(f"dt must be > 0 s, got {self.dt!r}")
        if not (math.isfinite(self.lam) and self.lam < 0.0):
            raise ValueError(f"lam must be < 0 1/s, got {self.lam!r}")
        if not (math.isfinite(self.b) and self.b != 0.0):
            raise ValueError(f"b must be finite and non-zero, got {self.b!r}")
        if not (self.g_limit > 0.0 and self.u0 > 0.0):
            raise ValueError("g_limit and u0 must be > 0")


@dataclass
class IDTSM:
    """Integral DTSM controller; ``step(e)`` returns u_k and leaves g_k in ``self.g``.

    Parameters
    ----------
    params : IDTSMParams
        The plant, the period, the eigenvalue and the limits.
    """

    params: IDTSMParams
    g: float = field(default=0.0, init=False)  #: integral sliding variable g_k (6.20)
    #: the last step was in the law's linear region: (6.21) has no sign term, so it is left only
    #: where a bound acts (the integrator at +-g_limit, the output at +-U0)
    linear: bool = field(default=True, init=False)

    def __post_init__(self) -> None:
        p = self.params
        a_d, b_d = delta_model([[p.a]], [p.b], dt=p.dt)
        self.a_delta = float(a_d[0, 0])
        self.b_delta = float(b_d[0])
        self.lambda_delta = to_lambda_delta(p.lam, dt=p.dt)
        self.k_eq = (self.a_delta - self.lambda_delta) / self.b_delta  # (6.21)
        self._inv_b = 1.0 / self.b_delta
        self._t_lam = p.dt * self.lambda_delta
        self._inv_dt = 1.0 / p.dt
        self._e_prev = math.nan

    def reset(self) -> None:
        """Restore the initial state: the next error starts on the sliding line."""
        self.g = 0.0
        self.linear = True
        self._e_prev = math.nan

    def step(self, e: float) -> float:
        """One control update.

        Parameters
        ----------
        e : float
            The tracking error e_k = r_k - y_k.

        Returns
        -------
        float
            The control u_k [unit of u], |u_k| <= U0.
        """
        e_prev = self._e_prev
        linear = True
        if e_prev == e_prev:  # noqa: PLR0124 (not NaN: integrate (6.20))
            g = self.g + self._inv_b * (e - e_prev - self._t_lam * e_prev)
            lim = self.params.g_limit
            if g > lim:
                g, linear = lim, False
            elif g < -lim:
                g, linear = -lim, False
            self.g = g
        self._e_prev = e
        u = self.g * self._inv_dt + self.k_eq * e  # (6.21)
        u0 = self.params.u0
        if u > u0:
            u, linear = u0, False
        elif u < -u0:
            u, linear = -u0, False
        self.linear = linear
        return u
