"""``rig identify``: a_m and b_m of dw/dt = -a_m w + b_m u (3.5) from an experiment on the drive.

Experiment (``rig.identify.excitations.excitation``): u = u_0 + A prbs(t) (or steps); the position
(encoder counts) and u are recorded.

Estimation, robust to encoder quantisation, Coulomb friction and a transport
delay of k samples (model dw/dt = -a w + b u(t - k T) + d, d the offset):

1. Least squares in the position domain, the model integrated twice:
   theta_n - theta_0 = w_0 t_n - a int(theta - theta_0) + b int int u + d t_n^2/2,
   for each delay k = 0..max_delay; the k with the least residual wins.
   (Differencing quantised positions is biased, docs/identification.md: not used.)
2. Instrumental variables: the same regression with the measured position in
   the regressor replaced by the position simulated from step 1.
3. Output error: scipy.optimize.least_squares fits (a, b, d, theta_0, w_0) so the
   exact ZOH simulation matches the measured positions, started from step 2.
   Standard errors from cov = s^2 (J^T J)^-1 at the optimum; 95 % intervals
   +- 1.96 sigma.

The fit percentage is on held-out data, the last ``holdout`` of the record, not used for the
estimate (``rig.identify.fit_quality.held_out_fit``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from rig.identify.errors import IdentificationError
from rig.identify.excitations import excitation
from rig.identify.fit_quality import held_out_fit, quantum

__all__ = [
    "INPUTS",
    "IdentResult",
    "IdentificationError",
    "estimate",
    "excitation",
    "held_out_fit",
    "quantum",
    "simulate_positions",
    "virtual_experiment",
]


#: the inputs an experiment can replay: (unit of u, unit of b_m); with a torque, dw/dt =
#: -a_m w + b_m T holds with b_m = 1/J (and a_m = B/J)
INPUTS = {"voltage": ("V", "rad/(V s^2)"), "torque": ("N m", "1/(kg m^2)")}


@dataclass(frozen=True)
class IdentResult:
    """Identified (3.5) with its uncertainty; SI units."""

    a_m: float  #: [1/s] of (3.5)
    b_m: float  #: of (3.5), per unit of the input
    a_m_stderr: float  #: its standard error
    b_m_stderr: float  #: its standard error
    a_m_ci95: tuple[float, float]  #: its 95 % confidence interval
    b_m_ci95: tuple[float, float]  #: its 95 % confidence interval
    delay_samples: int  #: the input's delay [samples]
    offset: float  #: d [rad/s^2] (Coulomb friction and load as an acceleration)
    fit_percent: float  #: [%] the held-out fit
    dt: float  #: [s] the period
    samples: int  #: of the record
    input: str = "voltage"  #: what u was: "voltage" [V] (mode -1) or "torque" [N m] (CST)
    #: of ``samples``, those of cycles a real-time run skipped, filled in (``rundir.on_period_grid``)
    filled_samples: int = 0
    #: Coulomb and viscous friction and the inertia (``rig.identify.friction``), or why these
    #: data cannot separate them; None where not asked
    friction: dict[str, object] | None = None
    #: [rad/s] RMS of the held-out speed's residual y - y_hat
    residual_rms: float = math.nan
    #: [rad/s] RMS of the encoder's quantisation noise in that speed, q / (T sqrt(24))
    quantisation_rms: float = math.nan

    @property
    def input_unit(self) -> str:
        return INPUTS[self.input][0]

    @property
    def b_m_unit(self) -> str:
        """b_m per unit of the input: rad/(V s^2), or 1/(kg m^2) (b_m = 1/J) for a torque."""
        return INPUTS[self.input][1]

    def as_dict(self) -> dict[str, object]:
        """JSON-ready (identification.json).

        Returns
        -------
        dict[str, object]
            The fields by name.
        """
        return {**asdict(self), "input_unit": self.input_unit, "b_m_unit": self.b_m_unit}


def _shift(u: np.ndarray, k: int) -> np.ndarray:
    """u delayed by k samples (the first k repeat u_0: the drive held the first command)."""
    return np.concatenate([np.full(k, u[0]), u[: len(u) - k]]) if k else u


def simulate_positions(p: np.ndarray, u: np.ndarray, dt: float, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH response of (3.5) with offset: p = (a, b, d, theta_0, w_0); returns (theta, w) per sample.

    Parameters
    ----------
    p : np.ndarray
        (a, b, d, theta_0, w_0).
    u : np.ndarray
        The input per sample.
    dt : float
        [s] the period.
    k : int
        The delay [samples].

    Returns
    -------
    tuple[np.ndarray, np.ndarray]
        (theta [rad], w [rad/s]).
    """
    import scipy.signal

    a, b, d, theta0, w0 = p
    alpha = math.exp(-a * dt)
    g = (1.0 - alpha) / a if a != 0.0 else dt
    h = (dt - g) / a if a != 0.0 else dt * dt / 2.0
    v = b * _shift(u, k) + d
    w_forced = scipy.signal.lfilter([0.0, g], [1.0, -alpha], v)
    w = w_forced + w0 * alpha ** np.arange(len(u))
    increments = g * w + h * v
    theta = theta0 + np.concatenate([[0.0], np.cumsum(increments[:-1])])
    return theta, w


def _regressors(theta: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows [t, -int(theta - theta_0), int int u, t^2/2] and target theta - theta_0."""
    n = len(theta)
    t = np.arange(n) * dt
    y = theta - theta[0]
    int_theta = np.concatenate([[0.0], np.cumsum((y[1:] + y[:-1]) * dt / 2.0)])
    v = np.concatenate([[0.0], np.cumsum(u[:-1] * dt)])  # int u, exact for a held u
    w = np.concatenate([[0.0], np.cumsum(v[:-1] * dt + u[:-1] * dt * dt / 2.0)])  # int int u, exact
    return np.column_stack([t, -int_theta, w, t * t / 2.0]), y


def _checked(u: np.ndarray, theta: np.ndarray, dt: float, input: str) -> tuple[np.ndarray, np.ndarray]:
    """(u, theta) as arrays of floats; IdentificationError where they cannot identify (3.5)."""
    if input not in INPUTS:
        raise IdentificationError(f"input {input!r}: voltage or torque")
    u = np.asarray(u, dtype=float)
    theta = np.asarray(theta, dtype=float)
    if u.shape != theta.shape:
        raise IdentificationError(f"u and theta differ in length: {u.shape} vs {theta.shape}")
    if len(u) < 50:
        raise IdentificationError(f"only {len(u)} samples: record at least 50")
    if float(np.std(u)) < 1e-9 * max(1.0, float(np.max(np.abs(u)))):
        raise IdentificationError(
            "the input is constant: b_m and the friction offset cannot be told apart (use --excitation prbs)"
        )
    travel = float(np.max(theta) - np.min(theta))
    if travel < 1e-3 * len(u) * dt:
        raise IdentificationError(f"the motor did not move (position changed by {travel:.3g} rad): stalled?")
    return u, theta


def delay_scan(
    u: np.ndarray, theta: np.ndarray, dt: float, max_delay: int, extra: np.ndarray | None = None
) -> tuple[int, np.ndarray]:
    """Position-domain least squares for each delay k of u, with the regressors of
    ``_regressors`` and the columns ``extra``; (k, [w0, a, b, d, *extra's]) of the least residual."""
    best = None
    for k in range(max_delay + 1):
        phi, y = _regressors(theta, _shift(u, k), dt)
        if extra is not None:
            phi = np.column_stack([phi, extra])
        coef, *_ = np.linalg.lstsq(phi, y, rcond=None)
        rss = float(np.sum((y - phi @ coef) ** 2))
        if best is None or rss < best[0]:
            best = (rss, k, coef)
    if best is None:
        raise IdentificationError(f"max_delay must be >= 0, got {max_delay}")
    return best[1], best[2]


def _least_squares(u: np.ndarray, theta: np.ndarray, dt: float, max_delay: int) -> tuple[int, np.ndarray]:
    """Step 1: position-domain least squares for each delay; (delay, [w0, a, b, d]) of the best."""
    k, coef = delay_scan(u, theta, dt, max_delay)
    a, b = coef[1], coef[2]
    if not (a > 0.0 and math.isfinite(b)):
        raise IdentificationError(
            f"least squares gave a_m = {a:.4g} (must be > 0): excitation too weak or too slow"
        )
    return k, coef


def _instrumental(u: np.ndarray, theta: np.ndarray, dt: float, k: int, coef: np.ndarray) -> np.ndarray:
    """Step 2: instrumental variables, regressors from the simulated, noise-free position."""
    w0, a, b, d = coef
    sim, _ = simulate_positions(np.array([a, b, d, theta[0], w0]), u, dt, k)
    z, _ = _regressors(sim, _shift(u, k), dt)
    phi, y = _regressors(theta, _shift(u, k), dt)
    try:
        solved: np.ndarray = np.linalg.solve(z.T @ phi, z.T @ y)
    except np.linalg.LinAlgError as exc:
        raise IdentificationError(f"instrumental variables failed: {exc}") from exc
    return solved


def _output_error(
    u: np.ndarray, theta: np.ndarray, dt: float, k: int, coef: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Step 3: the output-error fit from ``coef``; (parameters, standard errors)."""
    w0, a, b, d = coef

    import scipy.optimize

    def residual(p: np.ndarray) -> np.ndarray:
        err: np.ndarray = simulate_positions(p, u, dt, k)[0] - theta
        return err

    start = np.array([max(a, 1e-6), b, d, theta[0], w0])
    fit = scipy.optimize.least_squares(residual, start, x_scale="jac", method="lm")
    s2 = float(fit.fun @ fit.fun) / max(1, len(u) - len(fit.x))
    try:
        cov = s2 * np.linalg.inv(fit.jac.T @ fit.jac)
    except np.linalg.LinAlgError as exc:
        raise IdentificationError(
            "the output-error fit is singular: the data do not excite the model"
        ) from exc
    return fit.x, np.sqrt(np.maximum(np.diag(cov), 0.0))


def _three_steps(
    u: np.ndarray, theta: np.ndarray, dt: float, max_delay: int
) -> tuple[int, np.ndarray, np.ndarray]:
    """(delay, p, standard errors) by the module doc's steps 1-3 on the record to fit."""
    k, coef = _least_squares(u, theta, dt, max_delay)
    p, se = _output_error(u, theta, dt, k, _instrumental(u, theta, dt, k, coef))
    return k, p, se


def estimate(
    u: np.ndarray,
    theta: np.ndarray,
    dt: float,
    *,
    max_delay: int = 5,
    holdout: float = 0.3,
    input: str = "voltage",
) -> IdentResult:
    """Identify (3.5) from the command u [V, or N m with ``input="torque"``] and the measured
    position theta [rad] per sample.

    Parameters
    ----------
    u : np.ndarray
        The command [V, or N m].
    theta : np.ndarray
        The position [rad].
    dt : float
        [s] the period.
    max_delay : int, optional
        The most delay tried [samples].
    holdout : float, optional
        The share of the record kept for the fit figure.
    input : str, optional
        "voltage" or "torque".

    Returns
    -------
    IdentResult
        The model.

    Raises
    ------
    IdentificationError
        If the record is too short, the motor did not move, or the fit fails.
    """
    u, theta = _checked(u, theta, dt, input)
    n_fit = int(len(u) * (1.0 - holdout))
    uf, thf = u[:n_fit], theta[:n_fit]
    k, p, se = _three_steps(uf, thf, dt, max_delay)
    _, w_model = simulate_positions(p, u, dt, k)
    fit_pct, residual, floor = held_out_fit(theta, w_model, n_fit, dt)
    a_m, b_m = float(p[0]), float(p[1])
    return IdentResult(
        a_m=a_m,
        b_m=b_m,
        a_m_stderr=float(se[0]),
        b_m_stderr=float(se[1]),
        a_m_ci95=(a_m - 1.96 * float(se[0]), a_m + 1.96 * float(se[0])),
        b_m_ci95=(b_m - 1.96 * float(se[1]), b_m + 1.96 * float(se[1])),
        delay_samples=int(k),
        offset=float(p[2]),
        fit_percent=fit_pct,
        dt=dt,
        samples=len(u),
        input=input,
        residual_rms=residual,
        quantisation_rms=floor,
    )


def virtual_experiment(
    a_m: float,
    b_m: float,
    *,
    dt: float = 1e-3,
    duration: float = 5.0,
    seed: int = 0,
    counts_per_rev: int = 4096,
    coulomb: float = 0.05,
    delay: int = 1,
    noise_counts: float = 0.3,
    u0: float = 3.0,
    amplitude: float = 2.0,
    clock: float = 0.02,
    kind: str = "prbs",
) -> tuple[np.ndarray, np.ndarray]:
    """The bench's experiment without a bus: the exact (3.7) response with Coulomb friction
    (an acceleration ``coulomb`` b_m against the motion, i.e. ``coulomb`` volts), a delay of
    ``delay`` samples, Gaussian position noise of ``noise_counts`` counts, then quantisation.

    Parameters
    ----------
    a_m, b_m : float
        The motor (3.7).
    dt : float, optional
        [s] the period.
    duration : float, optional
        [s].
    seed : int, optional
        Of the excitation and the noise.
    counts_per_rev : int, optional
        The encoder's.
    coulomb : float, optional
        [V] the Coulomb friction.
    delay : int, optional
        [samples].
    noise_counts : float, optional
        Gaussian noise [counts].
    u0, amplitude : float, optional
        [V] the excitation's mean and amplitude.
    clock : float, optional
        [s] a bit's hold.
    kind : str, optional
        "prbs" or "steps".

    Returns
    -------
    tuple[np.ndarray, np.ndarray]
        (u [V], theta [rad]).
    """
    rng = np.random.default_rng(seed + 10_000)
    u = excitation(kind, u0=u0, amplitude=amplitude, clock=clock, dt=dt, duration=duration, seed=seed)
    theta, _ = simulate_positions(np.array([a_m, b_m, -coulomb * b_m, 0.0, 0.0]), u, dt, delay)
    cpr = counts_per_rev / (2.0 * math.pi)
    measured = np.floor(theta * cpr + rng.normal(0.0, noise_counts, len(theta))) / cpr
    return u, measured
