"""RL current dynamics behind a regular-sampled PWM converter (dq-current paper).

Two plants, both stepped once per sample T_s with the voltage reference u_ref
computed at that sample and the frame speed omega_k held over the sample:

- ``ExactDqPlant``: the exact discrete complex plant (29) / Table I, in the
  rotating frame, for any dead-time fraction m = 1 - T_d/T_s of (21).
- ``StationaryRLConverter``: the higher-fidelity model the emulated converter
  runs: continuous RL (1) in the stationary frame, the converter's alpha-beta
  voltage held over each PWM update interval and applied after the true delay
  T_d, a rotating source voltage (back EMF or grid), an optional converter
  voltage limit, and the current sampled at the strategy's instants.

Complex numbers: x = x_d + j x_q (dq) or x_alpha + j x_beta [A, V].
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field

__all__ = ["ExactDqPlant", "RLParams", "StationaryRLConverter"]


@dataclass(frozen=True, slots=True)
class RLParams:
    """R_1 [Ohm] >= 0, L_1 [H] > 0, T_s [s] > 0 and m of (21) in [0, 1].

    Raises
    ------
    ValueError
        If one is out of its range.
    """

    r1: float  #: R_1 [Ohm] >= 0
    l1: float  #: L_1 [H] > 0
    ts: float  #: T_s [s] > 0
    m: float = 0.0  #: the dead-time fraction m of (21), in [0, 1]

    def __post_init__(self) -> None:
        for name in ("l1", "ts"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        if not (math.isfinite(self.r1) and self.r1 >= 0.0):
            raise ValueError(f"r1 must be a finite number >= 0, got {self.r1!r}")
        if not (0.0 <= self.m <= 1.0):
            raise ValueError(f"m (dead-time fraction, (21)) must be in [0, 1], got {self.m!r}")


def _decay(s: complex, h: float) -> complex:
    """e^{-s h}: the free response of di/dt = -s i over h [s]."""
    return cmath.exp(-s * h)


def _held_gain(s: complex, l1: float, h: float) -> complex:
    """Response of L di/dt = -L s i + u to u held over h: (1 - e^{-s h})/(L s), h/L at s = 0."""
    if s == 0:
        return complex(h / l1)
    return (1.0 - cmath.exp(-s * h)) / (l1 * s)


@dataclass
class ExactDqPlant:
    """The exact discrete plant (29) as a state recursion, omega_k free to vary.

    Over sample k the dq voltage u_{k-1} e^{-j omega_k T_d} is applied for
    T_d = (1 - m) T_s, then u_k e^{-j omega_k T_d} for m T_s (17), (20), on
    L di/dt = -(R_1 + j omega_k L_1) i + u - u_i (6), giving

        i_{k+1} = alpha_1 i_k + alpha_2 g((1-m) T_s) u'_{k-1} + g(m T_s) u'_k - g(T_s) u_i,

    with alpha_1, alpha_2 of (29) and g(h) = (1 - e^{-s h})/(R_1 + j omega_k L_1),
    s = 1/tau_1 + j omega_k. Its transfer function is (29) exactly (tested).
    A varying omega_k is held over each sample and the delay rotation uses the
    present omega_k. Coefficients are recomputed only when omega_k changes.
    """

    params: RLParams  #: the RL load and its sampling
    i: complex = 0j  #: dq current at the present sample [A]
    _u_prev: complex = field(default=0j, init=False, repr=False)
    _omega: float = field(default=math.nan, init=False, repr=False)
    _c: tuple[complex, complex, complex, complex] = field(default=(0j, 0j, 0j, 0j), init=False, repr=False)

    def _coefficients(self, omega_k: float) -> tuple[complex, complex, complex, complex]:
        p = self.params
        s = complex(p.r1 / p.l1, omega_k)
        d1, d2 = (1.0 - p.m) * p.ts, p.m * p.ts
        rot = cmath.exp(-1j * omega_k * d1)  # e^{-j omega_k T_d} (17)
        alpha1 = _decay(s, p.ts)
        alpha2 = _decay(s, d2)
        return (
            alpha1,
            alpha2 * _held_gain(s, p.l1, d1) * rot,
            _held_gain(s, p.l1, d2) * rot,
            _held_gain(s, p.l1, p.ts),
        )

    def transfer(self, z: complex, omega_k: float) -> complex:
        """G_plant(z, m) of (29) at constant omega_k, as printed (R_1 + j omega_k L_1 != 0).

        Parameters
        ----------
        z : complex
            The z-domain point.
        omega_k : float
            [rad/s] the frame's speed.

        Returns
        -------
        complex
            G_plant(z, m).
        """
        p = self.params
        alpha0 = math.exp(-p.ts * p.r1 / p.l1)
        alpha1 = alpha0 * cmath.exp(-1j * omega_k * p.ts)
        alpha2 = math.exp(-p.m * p.ts * p.r1 / p.l1) * cmath.exp(-1j * omega_k * p.m * p.ts)
        bracket = 1.0 / z - alpha2 * (z - 1.0) / (z * (z - alpha1))
        return bracket * cmath.exp(-1j * omega_k * (1.0 - p.m) * p.ts) / complex(p.r1, omega_k * p.l1)

    def step(self, u_ref: complex, omega_k: float, u_i: complex = 0j) -> complex:
        """Apply u_ref [V] computed at this sample; return the current at the next sample [A].

        Parameters
        ----------
        u_ref : complex
            [V] the dq reference.
        omega_k : float
            [rad/s] the frame's speed.
        u_i : complex, optional
            [V] the source's dq voltage.

        Returns
        -------
        complex
            [A] the dq current at the next sample.
        """
        if omega_k != self._omega:
            self._c = self._coefficients(omega_k)
            self._omega = omega_k
        a1, b_prev, b_now, b_src = self._c
        self.i = a1 * self.i + b_prev * self._u_prev + b_now * u_ref - b_src * u_i
        self._u_prev = u_ref
        return self.i


@dataclass
class StationaryRLConverter:
    """Continuous RL (1) in alpha-beta behind a converter that holds its voltage.

    At sample k (time k T_s) the current is sampled and transformed with the
    frame angle theta_k, (4). The reference u_ref computed there is turned into
    an alpha-beta voltage, limited to |u| <= u_max (the converter's linear
    range, U_DC/sqrt(3) for sine-triangle PWM with third harmonic), and held
    from k T_s + T_d for one update interval T_s (14). The source voltage
    u_i = u_i^dq e^{j theta(t)} rotates with the frame.

    Each interval is split at the update instant and into ``n_sub`` sub-steps
    per part; over a sub-step the RL equation is integrated exactly (held
    voltage, rotating source), so the result does not depend on n_sub and the
    current between samples is available (``peak`` is the largest |i| seen).

    The dq -> alpha-beta angle: (17) models the converter voltage as the dq
    reference held in the rotating frame. A real modulator holds it in
    alpha-beta, so its dq image turns by omega_k T_s over the interval. With
    ``hold_angle="middle"`` (default) the reference is turned with
    theta_k + omega_k T_s/2, so the held vector equals the model's at the middle
    of its interval; with ``"sample"`` it is turned with theta_k, and the mean
    applied vector lags by omega_k T_s/2 (6.7 deg at omega_k/omega_s = 1/27),
    which shows up as d-axis coupling.

    Raises
    ------
    ValueError
        If ``n_sub`` < 1, ``hold_angle`` is neither, or ``u_max`` <= 0.
    """

    params: RLParams  #: the RL load and its sampling
    u_max: float = math.inf  #: [V] the converter's voltage limit (inf: none)
    n_sub: int = 4  #: RK4 sub-steps per period, >= 1
    hold_angle: str = "middle"  #: "middle" or "sample": the angle a reference is turned with
    i_ab: complex = 0j  #: alpha-beta current [A]
    theta: float = 0.0  #: frame angle at the present sample [rad]
    peak: float = 0.0  #: largest |i_ab| seen, between samples included [A]
    _u_held: complex = field(default=0j, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.n_sub < 1:
            raise ValueError(f"n_sub must be >= 1, got {self.n_sub!r}")
        if self.hold_angle not in ("middle", "sample"):
            raise ValueError(f"hold_angle must be 'middle' or 'sample', got {self.hold_angle!r}")
        if not (self.u_max > 0.0):
            raise ValueError(f"u_max must be > 0 V, got {self.u_max!r}")

    @property
    def i(self) -> complex:
        """dq current at the present sample, i_ab e^{-j theta_k} (4) [A]."""
        return self.i_ab * cmath.exp(-1j * self.theta)

    def advance(self, u_ab: complex, omega: float, h: float, u_i: complex = 0j) -> None:
        """Integrate h [s] with the alpha-beta voltage u_ab [V] held (limited to u_max), the
        source u_i (dq) [V] rotating at omega [rad/s]; the frame angle advances by omega h.

        Parameters
        ----------
        u_ab : complex
            [V] the alpha-beta voltage held.
        omega : float
            [rad/s] the source's and frame's speed.
        h : float
            [s].
        u_i : complex, optional
            [V] the source's dq voltage.
        """
        p = self.params
        mag = abs(u_ab)
        if mag > self.u_max:
            u_ab *= self.u_max / mag
        a = p.r1 / p.l1
        h_sub = h / self.n_sub
        decay = math.exp(-a * h_sub)
        g_u = _held_gain(complex(a), p.l1, h_sub)
        rot = cmath.exp(1j * omega * h_sub)
        s_src = complex(a, omega)
        # rotating source: int_0^h e^{-a(h-t)} e^{j omega t} dt / L
        #                  = (e^{j omega h} - e^{-a h}) / (L (a + j omega))
        g_src = (rot - decay) / (p.l1 * s_src) if s_src != 0 else complex(h_sub / p.l1)
        src = u_i * cmath.exp(1j * self.theta)
        i = self.i_ab
        peak = self.peak
        for _ in range(self.n_sub):
            i = decay * i + g_u * u_ab - g_src * src
            src *= rot
            peak = max(peak, abs(i))
        self.i_ab = i
        self.peak = peak
        self.theta = math.remainder(self.theta + omega * h, math.tau)

    def modulate(self, u_ref: complex, omega_k: float) -> complex:
        """The alpha-beta voltage the modulator holds for dq reference u_ref computed now (``hold_angle``).

        Parameters
        ----------
        u_ref : complex
            [V] the dq reference.
        omega_k : float
            [rad/s] the frame's speed.

        Returns
        -------
        complex
            [V] the alpha-beta voltage.
        """
        turn = self.theta + (0.5 * omega_k * self.params.ts if self.hold_angle == "middle" else 0.0)
        return u_ref * cmath.exp(1j * turn)

    def step(self, u_ref: complex, omega_k: float, u_i: complex = 0j) -> complex:
        """Apply u_ref [V] (dq, computed at this sample); return the dq current at the next sample [A].

        Parameters
        ----------
        u_ref : complex
            [V] the dq reference.
        omega_k : float
            [rad/s] the frame's speed.
        u_i : complex, optional
            [V] the source's dq voltage.

        Returns
        -------
        complex
            [A] the dq current at the next sample.
        """
        p = self.params
        u_new = self.modulate(u_ref, omega_k)
        t_d = (1.0 - p.m) * p.ts
        if t_d > 0.0:
            self.advance(self._u_held, omega_k, t_d, u_i)
        if t_d < p.ts:
            self.advance(u_new, omega_k, p.ts - t_d, u_i)
        self._u_held = u_new
        return self.i
