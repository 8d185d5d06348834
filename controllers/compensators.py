"""Disturbance compensators of the drives paper, eqs. (6.29)-(6.35).

Both act on the sliding variable g_k of a DTSM loop whose control makes
g_{k+1} = T (u_c,k + d_k) (6.27), and return the compensational control u_c,k
that is added to the DTSM control (6.25).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["FirstOrderCompensator", "SecondOrderCompensator"]


@dataclass
class FirstOrderCompensator:
    """First-order compensator, eq. (6.30b): u_c,k = u_c,k-1 - alpha g_k / T.

    Its closed loop with the disturbance is (6.34),
    g(z) = T (z - 1) / (z (z - (1 - alpha))) d(z). The paper states stability for
    0 < alpha <= 1; the pole 1 - alpha is inside the unit circle for
    0 < alpha < 2, which is the range accepted here (a known misprint).

    Raises
    ------
    ValueError
        If alpha is outside (0, 2) or dt is not a finite period > 0.
    """

    alpha: float  #: compensator gain, 0 < alpha < 2 [-]
    dt: float  #: sample period T [s]
    u_c: float = 0.0  #: last compensational control u_c,k-1 [control unit]

    def __post_init__(self) -> None:
        if not (0.0 < self.alpha < 2.0):
            raise ValueError(f"alpha must be in (0, 2), got {self.alpha!r}")
        if not (math.isfinite(self.dt) and self.dt > 0.0):
            raise ValueError(f"dt must be > 0 s, got {self.dt!r}")
        self._gain = self.alpha / self.dt

    def reset(self) -> None:
        """Forget the disturbance estimate."""
        self.u_c = 0.0

    def step(self, g: float) -> float:
        """One step of (6.30b).

        Parameters
        ----------
        g : float
            The sliding variable g_k.

        Returns
        -------
        float
            The compensational control u_c,k [control unit].
        """
        self.u_c -= self._gain * g
        return self.u_c


@dataclass
class SecondOrderCompensator:
    """Second-order compensator, Remark 5 and eq. (6.35).

    The previous disturbance is estimated by (6.29), d_est,k-1 = g_k/T - u_c,k-1,
    and the present one predicted linearly, d_k ~ 2 d_est,k-1 - d_est,k-2, so
    u_c,k = -(2 d_est,k-1 - d_est,k-2). Its transfer function is
    u_c2(z) = -(2z - 1) z / (T (z - 1)^2) g(z). Eq. (6.35) as printed has d(z) in
    place of g(z) and no minus sign; the sign and variable here are the ones
    (6.29) gives, consistent with (6.33). With it, g_{k+1} = T (d_k - 2 d_k-1 + d_k-2).

    Raises
    ------
    ValueError
        If dt is not a finite period > 0.
    """

    dt: float  #: sample period T [s]
    u_c: float = 0.0  #: last compensational control u_c,k-1
    d_prev: float = 0.0  #: last estimate d_est,k-2

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0.0):
            raise ValueError(f"dt must be > 0 s, got {self.dt!r}")
        self._inv_dt = 1.0 / self.dt

    def reset(self) -> None:
        """Forget the disturbance estimates."""
        self.u_c = 0.0
        self.d_prev = 0.0

    def step(self, g: float) -> float:
        """One step of (6.35).

        Parameters
        ----------
        g : float
            The sliding variable g_k.

        Returns
        -------
        float
            The compensational control u_c,k [control unit].
        """
        d_est = g * self._inv_dt - self.u_c  # (6.29)
        self.u_c = -(2.0 * d_est - self.d_prev)
        self.d_prev = d_est
        return self.u_c
