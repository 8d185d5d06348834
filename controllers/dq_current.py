"""Current control in the rotating dq frame, complex-vector form (dq-current paper).

Currents and voltages are complex numbers x = x_d + j x_q [A, V]; omega_k is the
frame speed [rad/s], T_s the sample period [s]. Both controllers run in the
incremental (velocity) form u_k = u_{k-1} + K (e_k - z_0 e_{k-1}), which is
R(z) = K (z - z_0)/(z - 1) exactly, lets K and z_0 follow omega_k from step to
step without a bump, and gives anti-windup for free: u_{k-1} is the output
actually applied (after the voltage limit), so the integral never runs away.

Strategies are named as in Table I; ``PWM_STRATEGIES`` gives m of (21).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field

__all__ = [
    "PWM_STRATEGIES",
    "ComplexVectorCurrentController",
    "DqCurrentParams",
    "DqPI",
    "DqPIParams",
    "dead_time_fraction",
    "pi_gains_like",
]

#: m = 1 - T_d/T_s of (21) for the three regular-sampled PWM strategies of Table I.
PWM_STRATEGIES: dict[str, float] = {"s-pwm-start": 0.0, "s-pwm-middle": 0.5, "a-pwm-double": 0.0}


def dead_time_fraction(strategy: str) -> float:
    """The fraction m of (21) for a PWM strategy.

    Parameters
    ----------
    strategy : str
        One of ``PWM_STRATEGIES``.

    Returns
    -------
    float
        m = 1 - T_d/T_s.

    Raises
    ------
    ValueError
        Naming the strategy when it is unknown.
    """
    try:
        return PWM_STRATEGIES[strategy]
    except KeyError:
        known = ", ".join(PWM_STRATEGIES)
        raise ValueError(f"unknown PWM strategy {strategy!r}; known: {known}") from None


def _check_positive(**values: float) -> None:
    for name, v in values.items():
        if not (math.isfinite(v) and v > 0.0):
            raise ValueError(f"{name} must be a finite number > 0, got {v!r}")


def _check_limit(u_max: float) -> None:
    if not (u_max > 0.0):  # inf (no limit) passes, NaN does not
        raise ValueError(f"u_max must be > 0 V (inf for no limit), got {u_max!r}")


@dataclass(frozen=True, slots=True)
class DqCurrentParams:
    """Parameters of the controller (32)-(34) / (32), (37).

    Parameters
    ----------
    r1 : float
        The plant's R_1 [Ohm], >= 0.
    l1 : float
        The plant's L_1 [H], > 0.
    ts : float
        Sample period T_s [s], > 0.
    gamma : float
        Tuning factor of (34), > 0.
    strategy : str
        PWM strategy of Table I (``PWM_STRATEGIES``).
    u_max : float
        Converter voltage limit |u| [V] (inf: none).

    Raises
    ------
    ValueError
        If a value is out of its range or the strategy is unknown.
    """

    r1: float
    l1: float
    ts: float
    gamma: float
    strategy: str = "s-pwm-start"
    u_max: float = math.inf

    def __post_init__(self) -> None:
        _check_positive(l1=self.l1, ts=self.ts, gamma=self.gamma)
        _check_limit(self.u_max)
        if not (math.isfinite(self.r1) and self.r1 >= 0.0):
            raise ValueError(f"r1 must be a finite number >= 0, got {self.r1!r}")
        dead_time_fraction(self.strategy)

    @property
    def td(self) -> float:
        """Dead time T_d = (1 - m) T_s [s], (11)-(13), (21)."""
        return (1.0 - dead_time_fraction(self.strategy)) * self.ts

    @property
    def tau1(self) -> float:
        """tau_1 = L_1 / R_1 [s] (inf when R_1 = 0)."""
        return self.l1 / self.r1 if self.r1 > 0.0 else math.inf


@dataclass
class ComplexVectorCurrentController:
    """The discrete complex-vector current controller with improved decoupling.

    R(z) = K_rz (z - z_0)/(z - 1) e^{j omega_k T_d}   (32)
    z_0 = alpha_1 = alpha_0 e^{-j omega_k T_s}, alpha_0 = e^{-T_s/tau_1}   (33)
    K_rz = K_0 (1 + j omega_k tau_1)(K_1 + j K_2)   (34) for s-PWM-start and
    a-PWM-double, and (37) for s-PWM-middle (beta_0 = e^{-T_s/(2 tau_1)},
    half angle omega_k T_s / 2).

    (34) is evaluated in its closed form K_rz = gamma (R_1 + j omega_k L_1)/(1 - alpha_1):
    K_0 (K_1 + j K_2) = gamma R_1 conj(1 - alpha_1)/|1 - alpha_1|^2. Likewise (37) is
    gamma (R_1 + j omega_k L_1)/(1 - beta_0 e^{-j omega_k T_s/2}). This form also
    holds for R_1 = 0, where (34) has 0 * inf. z_0 and K_rz are recomputed from
    the present omega_k every step (cmath, no allocation beyond complex scalars).
    With the exact plant (29) the open loop is gamma/(z^2 - z) (35) for
    s-PWM-start/a-PWM-double and gamma (z + beta_1)/(z^2 - z) (38) for s-PWM-middle,
    where beta_1 = beta_0 e^{-j omega_k T_s / 2}: the j is missing in the print.

    Parameters
    ----------
    params : DqCurrentParams
        The plant, the period, gamma, the strategy and the voltage limit.
    """

    params: DqCurrentParams
    _alpha0: float = field(init=False, repr=False)
    _beta0: float = field(init=False, repr=False)
    _middle: bool = field(init=False, repr=False)
    _v: complex = field(default=0j, init=False, repr=False)
    _e: complex = field(default=0j, init=False, repr=False)

    def __post_init__(self) -> None:
        p = self.params
        self._alpha0 = math.exp(-p.ts / p.tau1)
        self._beta0 = math.exp(-0.5 * p.ts / p.tau1)
        self._middle = p.strategy == "s-pwm-middle"

    def reset(self) -> None:
        """Forget the integral and the previous error."""
        self._v = 0j
        self._e = 0j

    def gains(self, omega_k: float) -> tuple[complex, complex, complex]:
        """The controller's gains at a frame speed, (32)-(34) / (37).

        Parameters
        ----------
        omega_k : float
            Frame speed [rad/s].

        Returns
        -------
        tuple of complex
            (K_rz, z_0, e^{j omega_k T_d}).
        """
        p = self.params
        z0 = self._alpha0 * cmath.exp(-1j * omega_k * p.ts)  # (33)
        if self._middle:
            den = 1.0 - self._beta0 * cmath.exp(-0.5j * omega_k * p.ts)  # (37)
        else:
            den = 1.0 - z0  # (34)
        k_rz = p.gamma * complex(p.r1, omega_k * p.l1) / den
        return k_rz, z0, cmath.exp(1j * omega_k * p.td)

    def transfer(self, z: complex, omega_k: float) -> complex:
        """R(z) of (32) at a constant frame speed.

        Parameters
        ----------
        z : complex
            The point of the z-plane.
        omega_k : float
            Frame speed [rad/s].

        Returns
        -------
        complex
            R(z).
        """
        k_rz, z0, rot = self.gains(omega_k)
        return k_rz * (z - z0) / (z - 1.0) * rot

    def step(self, i_ref: complex, i: complex, omega_k: float) -> complex:
        """One sample.

        Parameters
        ----------
        i_ref : complex
            dq current reference [A].
        i : complex
            Measured dq current [A].
        omega_k : float
            Frame speed [rad/s].

        Returns
        -------
        complex
            The voltage reference u_ref [V], |u_ref| <= u_max.
        """
        e = i_ref - i
        k_rz, z0, rot = self.gains(omega_k)
        v = self._v + k_rz * (e - z0 * self._e)
        u = v * rot  # PWM decoupling of (32)
        mag = abs(u)
        u_max = self.params.u_max
        if mag > u_max:  # anti-windup: keep the applied output as the state
            scale = u_max / mag
            u *= scale
            v *= scale
        self._v = v
        self._e = e
        return u


@dataclass(frozen=True, slots=True)
class DqPIParams:
    """Conventional dq PI: u = (k_p + k_i z/(z - 1)) e [+ j omega_k L_1 i].

    Parameters
    ----------
    k_p : float
        Proportional gain [V/A], > 0.
    k_i : float
        Integral gain [V/A per sample], >= 0.
    l1 : float
        L_1 [H] of the decoupling feed-forward.
    decouple : bool
        Add the feed-forward j omega_k L_1 i of the cross-coupling term in (6).
    u_max : float
        Voltage limit |u| [V] (inf: none).

    Raises
    ------
    ValueError
        If a gain or the limit is out of its range, or decoupling has no l1 > 0.
    """

    k_p: float
    k_i: float
    l1: float = 0.0
    decouple: bool = False
    u_max: float = math.inf

    def __post_init__(self) -> None:
        _check_positive(k_p=self.k_p)
        _check_limit(self.u_max)
        if not (math.isfinite(self.k_i) and self.k_i >= 0.0):
            raise ValueError(f"k_i must be a finite number >= 0, got {self.k_i!r}")
        if self.decouple and not (math.isfinite(self.l1) and self.l1 > 0.0):
            raise ValueError(f"decoupling needs l1 > 0 H, got {self.l1!r}")


def pi_gains_like(r1: float, l1: float, ts: float, gamma: float) -> tuple[float, float]:
    """(k_p, k_i) of the PI that equals (32)-(34) at omega_k = 0 with the same gamma.

    At omega_k = 0, K_rz = gamma R_1/(1 - alpha_0) and z_0 = alpha_0, so
    k_p = K_rz alpha_0 and k_i = K_rz (1 - alpha_0) = gamma R_1: the zero cancels
    the RL pole and the only difference left is the frame rotation, which is
    what the baseline is meant to show. For R_1 = 0 the limit is k_p = gamma L_1/T_s.

    Parameters
    ----------
    r1 : float
        R_1 [Ohm].
    l1 : float
        L_1 [H].
    ts : float
        Sample period T_s [s].
    gamma : float
        Tuning factor of (34).

    Returns
    -------
    tuple of float
        (k_p [V/A], k_i [V/A per sample]).
    """
    if r1 > 0.0:
        alpha0 = math.exp(-ts * r1 / l1)
        k = gamma * r1 / (1.0 - alpha0)
        return k * alpha0, k * (1.0 - alpha0)
    return gamma * l1 / ts, 0.0


@dataclass
class DqPI:
    """Synchronous-frame PI, the conventional baseline, with anti-windup.

    Incremental form u_k = u_{k-1} + k_p (e_k - e_{k-1}) + k_i e_k on the PI part;
    with ``decouple`` the feed-forward j omega_k L_1 i_k is added outside the
    integral. When |u| exceeds u_max the output is scaled to the limit and the PI
    part is set to what was applied minus the feed-forward (back-calculation).

    Parameters
    ----------
    params : DqPIParams
        Gains, decoupling and the voltage limit.
    """

    params: DqPIParams
    _v: complex = field(default=0j, init=False, repr=False)
    _e: complex = field(default=0j, init=False, repr=False)

    def reset(self) -> None:
        """Forget the integral and the previous error."""
        self._v = 0j
        self._e = 0j

    def step(self, i_ref: complex, i: complex, omega_k: float) -> complex:
        """One sample.

        Parameters
        ----------
        i_ref : complex
            dq current reference [A].
        i : complex
            Measured dq current [A].
        omega_k : float
            Frame speed [rad/s].

        Returns
        -------
        complex
            The voltage reference u_ref [V], |u_ref| <= u_max.
        """
        p = self.params
        e = i_ref - i
        v = self._v + p.k_p * (e - self._e) + p.k_i * e
        ff = 1j * omega_k * p.l1 * i if p.decouple else 0j
        u = v + ff
        mag = abs(u)
        if mag > p.u_max:
            u *= p.u_max / mag
            v = u - ff
        self._v = v
        self._e = e
        return u
