"""Friction and inertia: dw/dt = -a w + b u - c sign(w) + d, from data where the speed takes both signs.

The model extends (3.5) with Coulomb friction c [rad/s^2] against the motion; d is a
constant load (gravity, an offset) as an acceleration. Where u is a torque (CST), b = 1/J,
so the result is given in SI (``FrictionResult.si``): the inertia J = 1/b [kg m^2], the
viscous friction B = a J [N m s/rad], the Coulomb friction T_c = c J [N m] and the load
T_d = -d J [N m]. With a voltage, a = (k_e k_t / R + B)/J holds the back EMF and B together
and J is not separable from k_t/R: only c (and c/b, in volts) is given.

Estimation (as ``estimate``'s, in the position domain so the encoder's quantisation is not
differenced), with the sign of the speed s_k taken from the measured position, the sign of
the central difference theta_k+1 - theta_k-1 (0 where it is less than a count: the motor at
rest, where Coulomb friction balances the drive up to its break-away; D. Karnopp, "Computer
simulation of stick-slip friction in mechanical dynamic systems", J. Dyn. Sys., Meas.,
Control 107 (1985) 100-103):

1. least squares on theta_n - theta_0 = w_0 t_n - a int(theta - theta_0) + b int int u(t - kT)
   - c int int s + d t_n^2/2 for each delay k; the least residual wins;
2. output error: ``scipy.optimize.least_squares`` fits (a, b, c, d, theta_0, w_0, delta) so
   that the exact per-period solution with Karnopp's stick-slip (``rig.identify.stick_slip``) matches the
   measured positions; standard errors from s^2 (J^T J)^-1.

Separability: c and d are told apart only by the changes of s; with one sign of speed they
are one offset. ``estimate_friction`` says so (``separable`` false, with the reason) when the
speed keeps one sign, or when c's 95 % interval is wider than a fifth of c (the data do not
determine it), or when |corr(c, d)| > 0.99.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from rig.identify.estimate import (
    INPUTS,
    IdentificationError,
    IdentResult,
    _regressors,
    delay_scan,
    held_out_fit,
    quantum,
)
from rig.identify.stick_slip import (
    count_reversals,
    reverses,
    sign_changes,
    speed_signs,
    stick_slip_positions,
)

__all__ = [
    "FrictionResult",
    "count_reversals",
    "estimate_friction",
    "friction_excitation",
    "identify_with_friction",
    "one_sign_result",
    "reverses",
    "speed_signs",
]

#: a Coulomb friction whose 95 % half-width is above this fraction of it is not determined
RELATIVE_CI_MAX = 0.2
#: |corr(c, d)| above this: Coulomb friction and the load are one offset in these data
CORRELATION_MAX = 0.99


@dataclass(frozen=True)
class FrictionResult:
    """dw/dt = -a w + b u - c sign(w) + d identified; SI; ``separable`` false: c and d are not."""

    separable: bool  #: c and d could be told apart
    reason: str  #: why not separable ("" when it is)
    a: float  #: [1/s]
    b: float  #: per unit of the input
    c: float | None  #: Coulomb friction as an acceleration [rad/s^2]
    d: float  #: a constant load as an acceleration [rad/s^2] (with c, where not separable)
    a_stderr: float  #: its standard error
    b_stderr: float  #: its standard error
    c_stderr: float | None  #: its standard error
    d_stderr: float  #: its standard error
    delay_samples: int  #: the input's delay [samples]
    input: str  #: "voltage" or "torque"
    reversals: int  #: sign changes of the speed in the record (all of it, the held-out part too)
    #: the part of a period the input's change takes on top of ``delay_samples`` [-]
    delay_fraction: float = 0.0

    def si(self) -> dict[str, float | None]:
        """In a torque's terms: J [kg m^2], B [N m s/rad], T_c [N m], T_d [N m] and their standard
        errors (first order); with a voltage, the Coulomb friction in volts, c/b.

        Returns
        -------
        dict[str, float | None]
            The figures by name.
        """
        if self.input != "torque":
            if self.c is None or self.c_stderr is None:
                return {"coulomb_voltage": None, "coulomb_voltage_stderr": None}
            volts = self.c / self.b
            return {"coulomb_voltage": volts, "coulomb_voltage_stderr": self._c_over_b_stderr()}
        j = 1.0 / self.b
        rel_b = self.b_stderr / self.b
        return {
            "inertia": j,
            "inertia_stderr": j * rel_b,
            "viscous": self.a * j,
            "viscous_stderr": self.a * j * math.hypot(self.a_stderr / self.a, rel_b) if self.a else math.nan,
            "coulomb": None if self.c is None else self.c * j,
            "coulomb_stderr": None if self.c is None or self.c_stderr is None else self._c_over_b_stderr(),
            "load": -self.d * j,
        }

    def _c_over_b_stderr(self) -> float:
        """The standard error of c/b (T_c = c J in a torque's terms, c/b_m [V] in a voltage's):
        c's and b's relative errors in quadrature (first order)."""
        assert self.c is not None and self.c_stderr is not None
        rel_c = self.c_stderr / self.c if self.c else math.inf
        return abs(self.c / self.b) * math.hypot(rel_c, self.b_stderr / self.b)

    def as_dict(self) -> dict[str, object]:
        """JSON-ready.

        Returns
        -------
        dict[str, object]
            The fields and ``si``'s figures.
        """
        return {**asdict(self), **self.si()}


def friction_excitation(
    *, amplitude: float, clock: float, dt: float, duration: float, seed: int = 0
) -> np.ndarray:
    """Steps and slow ramps in both directions [unit of u]: a random binary signal of
    +-``amplitude`` held ``clock`` s per bit, on a triangle of +-``amplitude``/2 over the whole
    record (the slow ramps: the speed crosses zero at all speeds and accelerations).

    Parameters
    ----------
    amplitude : float
        [unit of u].
    clock : float
        [s] a bit's hold.
    dt : float
        [s] the period.
    duration : float
        [s].
    seed : int, optional
        Of the random bits.

    Returns
    -------
    np.ndarray
        u_k.
    """
    n = round(duration / dt)
    per_bit = max(1, round(clock / dt))
    rng = np.random.default_rng(seed)
    bits = rng.integers(0, 2, math.ceil(n / per_bit)) * 2 - 1
    steps = np.repeat(bits.astype(float), per_bit)[:n]
    phase = np.arange(n) / n
    triangle = 1.0 - 4.0 * np.abs(phase - 0.5)  # -1 .. 1 .. -1
    out: np.ndarray = amplitude * (steps + 0.5 * triangle)
    return out


def _start(
    u: np.ndarray, theta: np.ndarray, s: np.ndarray, dt: float, max_delay: int
) -> tuple[int, np.ndarray]:
    """Step 1: (delay, [w0, a, b, c, d]) by ``delay_scan`` with the column -int int s."""
    k, (w0, a, b, d, c) = delay_scan(u, theta, dt, max_delay, extra=-_regressors(theta, s, dt)[0][:, 2])
    return k, np.array([w0, a, b, c, d])


def _fit(
    u: np.ndarray, theta: np.ndarray, dt: float, max_delay: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int, np.ndarray]:
    """(p, standard errors, covariance, delay, reversals, signs) of the output-error fit."""
    import scipy.optimize

    s = speed_signs(theta, quantum(theta))
    reversals = sign_changes(s)
    k0, (w0, a, b, c, d) = _start(u, theta, s, dt, max_delay)
    if not a > 0.0:
        a = 1e-3 / (dt * len(u))  # no viscous term seen: start near zero, alpha < 1
    best = None
    for k in range(k0, min(k0 + 1, max_delay) + 1):  # the delay k + delta, delta from 0 to 1

        def residual(p: np.ndarray, k: int = k) -> np.ndarray:
            out: np.ndarray = stick_slip_positions(p, u, dt, k) - theta
            return out

        trial = scipy.optimize.least_squares(
            residual, np.array([a, b, c, d, theta[0], w0, 0.0]), x_scale="jac", method="lm"
        )
        if best is None or trial.cost < best[0].cost:
            best = (trial, k)
    assert best is not None
    fit, k = best
    s2 = float(fit.fun @ fit.fun) / max(1, len(u) - len(fit.x))
    try:
        cov = s2 * np.linalg.inv(fit.jac.T @ fit.jac)
    except np.linalg.LinAlgError:
        cov = np.full((7, 7), np.inf)
    return fit.x, np.sqrt(np.maximum(np.diag(cov), 0.0)), cov, k, reversals, s


def _judge(c: float, se: np.ndarray, cov: np.ndarray, reversals: int) -> str:
    """Why c and d cannot be told apart in these data ("" when they can)."""
    if reversals == 0:
        return "the speed kept one sign: Coulomb friction and a constant load are one offset"
    if not 1.96 * se[2] <= RELATIVE_CI_MAX * abs(c):
        return (
            f"Coulomb friction {c:.4g} +- {1.96 * se[2]:.2g} rad/s^2 (95 %) is not determined by these "
            "data: move more, and through zero more often (rig identify --excitation friction)"
        )
    corr = cov[2, 3] / (se[2] * se[3]) if se[2] > 0.0 and se[3] > 0.0 else 1.0
    if abs(corr) > CORRELATION_MAX:
        return f"Coulomb friction and the load are correlated ({corr:.3f}): reverse more often"
    return ""


def _check(u: np.ndarray, theta: np.ndarray, input: str) -> None:
    if input not in INPUTS:
        raise IdentificationError(f"input {input!r}: voltage or torque")
    if len(u) < 50 or u.shape != theta.shape:
        raise IdentificationError(f"u and theta: {u.shape} and {theta.shape} samples (at least 50, equal)")


def estimate_friction(
    u: np.ndarray, theta: np.ndarray, dt: float, *, max_delay: int = 5, input: str = "torque"
) -> FrictionResult:
    """Identify dw/dt = -a w + b u - c sign(w) + d from the command u [N m or V] and the
    measured position theta [rad] per sample (module doc).

    Parameters
    ----------
    u : np.ndarray
        The command [N m or V].
    theta : np.ndarray
        The position [rad].
    dt : float
        [s] the period.
    max_delay : int, optional
        The most delay tried [samples].
    input : str, optional
        "voltage" or "torque".

    Returns
    -------
    FrictionResult
        The friction model.
    """
    u, theta = np.asarray(u, dtype=float), np.asarray(theta, dtype=float)
    _check(u, theta, input)
    if not reverses(theta):
        return one_sign_result(input)
    p, se, cov, k, reversals, _ = _fit(u, theta, dt, max_delay)
    return _result(p, se, cov, k, reversals=reversals, input=input)


def one_sign_result(input: str) -> FrictionResult:
    """Not separable: the speed kept one sign.

    Parameters
    ----------
    input : str
        "voltage" or "torque".

    Returns
    -------
    FrictionResult
        A result saying so.
    """
    reason = _judge(0.0, np.zeros(4), np.zeros((4, 4)), 0)
    nan = math.nan
    return FrictionResult(False, reason, nan, nan, None, nan, nan, nan, None, nan, 0, input, 0)


def _result(
    p: np.ndarray, se: np.ndarray, cov: np.ndarray, k: int, *, reversals: int, input: str
) -> FrictionResult:
    a, b, c, d = (float(x) for x in p[:4])
    reason = _judge(c, se, cov, reversals)
    separable = not reason
    return FrictionResult(
        separable=separable,
        reason=reason,
        a=a,
        b=b,
        c=c if separable else None,
        d=d,
        a_stderr=float(se[0]),
        b_stderr=float(se[1]),
        c_stderr=float(se[2]) if separable else None,
        d_stderr=float(se[3]),
        delay_samples=k,
        input=input,
        reversals=reversals,
        delay_fraction=float(p[6]),
    )


def identify_with_friction(
    u: np.ndarray,
    theta: np.ndarray,
    dt: float,
    *,
    max_delay: int = 5,
    holdout: float = 0.3,
    input: str = "voltage",
) -> tuple[IdentResult, FrictionResult]:
    """(3.5) and the friction from data whose speed changes sign: the friction model fitted on
    the first 1 - ``holdout`` of the record, its a and b as a_m and b_m, d as the offset, the
    fit (as ``estimate``'s) on the rest.

    Parameters
    ----------
    u : np.ndarray
        The command.
    theta : np.ndarray
        The position [rad].
    dt : float
        [s] the period.
    max_delay : int, optional
        The most delay tried [samples].
    holdout : float, optional
        The share kept for the fit figure.
    input : str, optional
        "voltage" or "torque".

    Returns
    -------
    tuple[IdentResult, FrictionResult]
        (the model, the friction).
    """
    u, theta = np.asarray(u, dtype=float), np.asarray(theta, dtype=float)
    _check(u, theta, input)
    n_fit = int(len(u) * (1.0 - holdout))
    p, se, cov, k, fitted_reversals, _ = _fit(u[:n_fit], theta[:n_fit], dt, max_delay)
    friction = _result(p, se, cov, k, reversals=fitted_reversals, input=input)
    friction = replace(friction, reversals=count_reversals(theta))  # the record's, not the fitted part's
    fit_pct, residual, floor = held_out_fit(
        theta, np.gradient(stick_slip_positions(p, u, dt, k), dt), n_fit, dt
    )
    a_m, b_m = friction.a, friction.b
    result = IdentResult(
        a_m=a_m,
        b_m=b_m,
        a_m_stderr=friction.a_stderr,
        b_m_stderr=friction.b_stderr,
        a_m_ci95=(a_m - 1.96 * friction.a_stderr, a_m + 1.96 * friction.a_stderr),
        b_m_ci95=(b_m - 1.96 * friction.b_stderr, b_m + 1.96 * friction.b_stderr),
        delay_samples=k,
        offset=friction.d,
        fit_percent=fit_pct,
        dt=dt,
        samples=len(u),
        input=input,
        residual_rms=residual,
        quantisation_rms=floor,
    )
    return result, friction
