"""Cascade position / speed / current DTSM of section VII.D, with eq. (6.36) reconstructed.

Eq. (6.36) and section VI.D are missing from the paper's text; only Table V's
parameters (k_eq or k_s, c_s, k_r1, k_r2, k_int, U_0, beta, alpha) survive. The
loop law below is a RECONSTRUCTION, chosen to use exactly those parameters,
to reduce to the paper's published laws where they overlap, and to be provably
chattering-free. For a loop with state x (plant coordinates), reference x*,
delta model delta(x) = A_delta x + b_delta (u + d) and c_s b_delta ~ 1:

    (a) g_k   = c_s (x*_k - x_k)               sliding variable (6.10)
    (b) u_eq  = -k_s x_k + alpha c_1 (r_k - r_k-1)/T                 equivalent control (6.14)
              (k_s = c_s A_delta; the alpha term is the reference feed-forward,
               read as the "(6.36j) used only in the position controller")
    (c) u_r   = sgn(g_k) min{|g_k|/T, k_r1 |g_k|/T + k_r2 U_0}       bounded reaching, as (6.15a)
    (d) psi_k = sat(g_k / (c_1 beta))                               sign with boundary layer;
              beta is in the unit of the loop's error (rad, rad/s, A), c_1 = c_s[0]
    (e) v_k   = v_k-1 + T k_int psi_k                                integral of sgn(g): the
              super-twisting-like disturbance estimate; frozen while the output
              is saturated in the direction psi pushes, and |v| <= U_0
    (f) u_k   = U_0 sat((u_eq + u_r + v_k) / U_0)                     output saturation (Fig. 3)

Properties (tested): |u_k| <= U_0; near the line (c) is the deadbeat (6.14),
so g_{k+1} = -T (v_k + d_k) and the estimate error w = v + d obeys
w_k = (1 - kappa) w_k-1 with kappa = T^2 k_int / (c_1 beta): a constant load
leaves no steady-state error and, for 0 < kappa <= 1, the control increment
does not alternate in sign (no chattering). Table V gives kappa = 0.42
(current), 0.02 (speed), 0.64 (position). The integrator cannot wind up
past U_0 and is frozen while saturated.

Table V's speed-loop c_s = 0.0025 and k_eq = -0.0015 are not what (6.16) gives
for a_w = -0.6286, b_w = 340.7439, T = 0.5 ms (1/b_delta = 0.00294,
a_delta/b_delta = -0.00184); the printed values are used as given
(c_s b_delta = 0.85, a slightly softer reaching).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from controllers.design import DTSMDesign

__all__ = [
    "TABLE_V_CURRENT",
    "TABLE_V_POSITION",
    "TABLE_V_SPEED",
    "Cascade",
    "CascadeLoop",
    "CascadeLoopParams",
]


@dataclass(frozen=True, slots=True)
class CascadeLoopParams:
    """One loop of the reconstructed (6.36); the fields are Table V's symbols.

    Raises
    ------
    ValueError
        If ``c_s`` and ``k_s`` do not both have 1 or 2 entries, or a field is out of its range.
    """

    dt: float  #: sample period T [s]
    k_s: tuple[float, ...]  #: equivalent-control gain c_s A_delta (k_eq for n = 1)
    c_s: tuple[float, ...]  #: sliding vector, c_s b_delta ~ 1
    k_r1: float  #: linear reaching fraction, 0 < k_r1 <= 1 [-]
    k_r2: float  #: constant reaching fraction of U_0, >= 0 [-]
    k_int: float  #: integral gain of sgn(g) [unit of u / s]
    u0: float  #: output limit U_0 [unit of u]
    beta: float  #: boundary layer of sgn(g), in the unit of the loop's error
    alpha: float = 0.0  #: reference feed-forward weight, 0..1 [-]

    def __post_init__(self) -> None:
        n = len(self.c_s)
        if n not in (1, 2) or len(self.k_s) != n:
            raise ValueError(f"c_s and k_s must both have 1 or 2 entries, got {self.c_s}, {self.k_s}")
        if not (math.isfinite(self.dt) and self.dt > 0.0):
            raise ValueError(f"dt must be > 0 s, got {self.dt!r}")
        if not (0.0 < self.k_r1 <= 1.0):
            raise ValueError(f"k_r1 must be in (0, 1], got {self.k_r1!r}")
        checks = {
            "k_r2": self.k_r2 >= 0.0,
            "k_int": self.k_int >= 0.0,
            "u0": self.u0 > 0.0,
            "beta": self.beta > 0.0,
            "alpha": 0.0 <= self.alpha <= 1.0,
            "c_s[0]": self.c_s[0] != 0.0,
        }
        for name, ok in checks.items():
            if not ok:
                raise ValueError(f"{name} is out of range in {self!r}")

    @property
    def kappa(self) -> float:
        """Contraction of the disturbance-estimate error per step, T^2 k_int / (c_1 beta)."""
        return self.dt**2 * self.k_int / (abs(self.c_s[0]) * self.beta)

    @classmethod
    def from_design(cls, design: DTSMDesign, **kwargs: float) -> CascadeLoopParams:
        """Build from a ``design_dtsm`` result: k_s = c_delta A_delta, c_s = c_delta.

        Parameters
        ----------
        design : DTSMDesign
            The delta model and sliding vector of (6.9), (6.16).
        **kwargs : float
            The other fields (``k_r1``, ``k_r2``, ``k_int``, ``u0``, ``beta``, ``alpha``).

        Returns
        -------
        CascadeLoopParams
            The loop's parameters with ``dt``, ``k_s`` and ``c_s`` from the design.
        """
        return cls(dt=design.dt, k_s=design.c_delta_A_delta, c_s=design.c_delta, **kwargs)


#: Table V, q-axis current loop (T = 0.1 ms); k_eq printed truncated from -5.45217.
TABLE_V_CURRENT = CascadeLoopParams(
    dt=1e-4,
    k_s=(-5.4521,),
    c_s=(0.0236,),
    k_r1=0.25,
    k_r2=0.3,
    k_int=1000.0,
    u0=math.sqrt(2.0) * 230.0,
    beta=0.001,
)
#: Table V, speed loop (T = 0.5 ms).
TABLE_V_SPEED = CascadeLoopParams(
    dt=5e-4,
    k_s=(-0.0015,),
    c_s=(0.0025,),
    k_r1=0.12,
    k_r2=0.8,
    k_int=100.0,
    u0=5.02,
    beta=0.5,
)
#: Table V, position loop (T = 1 ms); reproduced by design_dtsm with lambda = -25 1/s.
TABLE_V_POSITION = CascadeLoopParams(
    dt=1e-3,
    k_s=(0.0, -0.9373),
    c_s=(0.0627, 0.0025),
    k_r1=0.9,
    k_r2=0.1,
    k_int=40.0,
    u0=30.0,
    beta=0.001,
    alpha=1.0,
)


@dataclass
class CascadeLoop:
    """One reconstructed (6.36) loop; ``step(r, y1, y2)`` returns u_k.

    Parameters
    ----------
    params : CascadeLoopParams
        The loop's Table V parameters.
    """

    params: CascadeLoopParams
    g: float = field(default=0.0, init=False)  #: sliding variable g_k
    v: float = field(default=0.0, init=False)  #: disturbance estimate v_k [unit of u]
    #: the last step was in the loop's linear region: its reaching linear (c), its sign inside the
    #: boundary layer (d: |g| <= c_1 beta) and its output below U_0 (f)
    linear: bool = field(default=True, init=False)

    def __post_init__(self) -> None:
        p = self.params
        self._c1, self._c2 = (*p.c_s, 0.0)[:2]
        self._k1, self._k2 = (*p.k_s, 0.0)[:2]
        self._n = len(p.c_s)
        self._inv_dt = 1.0 / p.dt
        self._kr1 = p.k_r1
        self._kr2u0 = p.k_r2 * p.u0
        self._kint_dt = p.k_int * p.dt
        self._inv_layer = 1.0 / (self._c1 * p.beta)
        self._ff = p.alpha * self._inv_dt
        self._u0 = p.u0
        self._r_prev = math.nan
        self._sat = 0  # +1 / -1 when the last output was at +U0 / -U0

    def reset(self) -> None:
        """Restore the initial state."""
        self.g = 0.0
        self.v = 0.0
        self.linear = True
        self._r_prev = math.nan
        self._sat = 0

    def step(self, r: float, y1: float, y2: float = 0.0) -> float:
        """One update from the reference and the measured state [y1, y2].

        For n = 2 the reference state is [r, (r_k - r_k-1)/T] (Euler backward).

        Parameters
        ----------
        r : float
            Reference x*_k of the loop's first state.
        y1 : float
            Measured first state.
        y2 : float
            Measured second state (n = 2 only).

        Returns
        -------
        float
            The loop's output u_k of (f), |u_k| <= U_0.
        """
        r_prev = self._r_prev if self._r_prev == self._r_prev else r
        self._r_prev = r
        dr = (r - r_prev) * self._inv_dt
        if self._n == 2:
            g = self._c1 * (r - y1) + self._c2 * (dr - y2)
            u = -(self._k1 * y1 + self._k2 * y2) + self._ff * (self._c1 * (r - r_prev))
        else:
            g = self._c1 * (r - y1)
            u = -self._k1 * y1
        self.g = g
        reach = self._kr1 * abs(g) * self._inv_dt
        linear = reach <= self._kr2u0
        reach = reach if linear else self._kr2u0
        u += reach if g >= 0.0 else -reach
        psi = g * self._inv_layer
        if psi > 1.0:
            psi, linear = 1.0, False
        elif psi < -1.0:
            psi, linear = -1.0, False
        if not ((self._sat > 0 and psi > 0.0) or (self._sat < 0 and psi < 0.0)):
            v = self.v + self._kint_dt * psi
            u0 = self._u0
            self.v = u0 if v > u0 else (-u0 if v < -u0 else v)
        u += self.v
        if u >= self._u0:
            self._sat, self.linear = 1, False
            return self._u0
        if u <= -self._u0:
            self._sat, self.linear = -1, False
            return -self._u0
        self._sat, self.linear = 0, linear
        return u


@dataclass
class Cascade:
    """Position -> speed -> current cascade of Fig. 3 / section VII.D, multirate.

    ``step`` is called at the current loop's period; the speed and position loops
    run every ``speed_every`` and ``position_every`` calls and hold their outputs
    (the speed reference [rad/s] and the q-current reference [A]) in between.

    Parameters
    ----------
    position, speed, current : CascadeLoop
        The three loops, outermost first.

    Raises
    ------
    ValueError
        If a rate ratio is below 1.
    """

    position: CascadeLoop
    speed: CascadeLoop
    current: CascadeLoop
    speed_every: int = 5  #: speed-loop period / current-loop period
    position_every: int = 10  #: position-loop period / current-loop period
    omega_ref: float = field(default=0.0, init=False)  #: last speed reference [rad/s]
    i_ref: float = field(default=0.0, init=False)  #: last q-current reference [A]
    _count: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if self.speed_every < 1 or self.position_every < 1:
            raise ValueError("loop rate ratios must be >= 1")

    def reset(self) -> None:
        """Restore the initial state of all three loops."""
        for loop in (self.position, self.speed, self.current):
            loop.reset()
        self.omega_ref = self.i_ref = 0.0
        self._count = 0

    def step(self, theta_ref: float, theta: float, omega: float, i_q: float) -> float:
        """One current-loop period.

        Parameters
        ----------
        theta_ref : float
            Position reference [rad].
        theta : float
            Measured position [rad].
        omega : float
            Measured speed [rad/s].
        i_q : float
            Measured q-axis current [A].

        Returns
        -------
        float
            The q-axis voltage u_q [V].
        """
        k = self._count
        self._count = k + 1
        if k % self.position_every == 0:
            self.omega_ref = self.position.step(theta_ref, theta, omega)
        if k % self.speed_every == 0:
            self.i_ref = self.speed.step(self.omega_ref, omega)
        return self.current.step(self.i_ref, i_q)
