"""The weak speed loop of ``rig identify``'s closed-loop experiment (law ``excited-speed``).

In CST the plant from the torque to the speed, b / (s + a) with a = B/J small, is nearly an
integrator: an open-loop excitation on a bias runs away, and one without a bias crosses zero
speed, where Coulomb friction is not linear. A PI speed loop on the host holds a constant
speed w_0 (one sign: Coulomb friction is a constant torque, which the integral takes) and the
excitation r is added to its command; the frequency response is G_ry / G_ru
(``rig.identify.frequency``), which needs no knowledge of the loop. The loop only has to be
stable and weak: its gains come from a previous identification's b (b_m = 1/J in CST), and
they need not be right (a J off by half changes the loop, not the estimate).

- ``speed_loop``: k_p = omega_c / b, k_i = k_p omega_c / 4 on b / s: the closed loop
  s^2 + omega_c s + omega_c^2 / 4 has a double pole at -omega_c / 2 (critically damped);
  omega_c = 2 pi f_min / 2 by default, so that over the band |S| = |1 / (1 + L)| >= 0.94 and
  the command is mostly r, and the start's transient is gone within 4.5 periods of 1/f_min.
- ``speed_swing``: the periodic speed response of the loop's model to one period of r,
  W = G R / (1 + G C) with (3.5)'s exact discrete G (``model_speed_response``) and the PI's
  C = k_p + k_i T / (z - 1), by the DFT of that period; w_0 is twice its peak by default.
- ``settle_time``: SETTLE over the slowest closed-loop pole, -omega_c / 2 with omega_c =
  4 k_i / k_p as ``speed_loop`` designs it: the start's transient dropped from the estimate.
- ``fit_model``: (3.5) fitted to the measured response, not to the time series.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rig.identify.estimate import IdentificationError, IdentResult
from rig.identify.frequency import COHERENCE_MIN, FrequencyResponse

__all__ = ["LOOP_FRACTION", "SPEED_MARGIN", "fit_model", "settle_time", "speed_loop", "speed_swing"]

#: the loop's crossover as a fraction of f_min
LOOP_FRACTION = 0.5
#: the loop's speed by default, over the excitation's peak swing
SPEED_MARGIN = 2.0


def speed_loop(b: float, crossover_hz: float) -> tuple[float, float]:
    """(k_p [unit of u per rad/s], k_i [unit of u per rad]) crossing over at ``crossover_hz``
    on b / s (b [rad/s^2 per unit of u]).

    Parameters
    ----------
    b : float
        [rad/s^2 per unit of u] of b / s, > 0.
    crossover_hz : float
        [Hz] the crossover, > 0.

    Returns
    -------
    tuple[float, float]
        (k_p [unit of u per rad/s], k_i [unit of u per rad]).

    Raises
    ------
    ValueError
        If ``b`` or ``crossover_hz`` is not > 0.
    """
    if not (b > 0.0 and math.isfinite(b)):
        raise ValueError(f"b_m = {b!r}: expected > 0")
    if not (crossover_hz > 0.0 and math.isfinite(crossover_hz)):
        raise ValueError(f"loop bandwidth {crossover_hz!r} Hz: expected > 0")
    w_c = 2.0 * math.pi * crossover_hz
    kp = w_c / b
    return kp, kp * w_c / 4.0


def speed_swing(r: np.ndarray, dt: float, *, a: float, b: float, kp: float, ki: float) -> float:
    """[rad/s] the peak of the speed's periodic response to ``r`` (one period, [unit of u]) in
    the loop on (3.5) = (a, b) with a period's delay (module doc).

    Parameters
    ----------
    r : np.ndarray
        One period of the excitation [unit of u].
    dt : float
        [s] the period T.
    a, b : float
        (3.5)'s a_m [1/s] and b_m.
    kp, ki : float
        The loop's gains (``speed_loop``).

    Returns
    -------
    float
        [rad/s] the peak.
    """
    from rig.identify.frequency import model_speed_response

    n = len(r)
    spectrum = np.fft.rfft(np.asarray(r, dtype=float) - float(np.mean(r)))
    f = np.fft.rfftfreq(n, dt)[1:]
    g = model_speed_response(a, b, dt, 1, f)
    z = np.exp(2j * math.pi * f * dt)
    c = kp + ki * dt / (z - 1.0)
    w = np.concatenate([[0.0], spectrum[1:] * g / (1.0 + g * c)])
    return float(np.max(np.abs(np.fft.irfft(w, n))))


def settle_time(kp: float, ki: float, settle: float) -> float:
    """[s] ``settle`` time constants of the loop's double pole at -omega_c / 2, omega_c = 4 k_i / k_p
    (``speed_loop``).

    Parameters
    ----------
    kp, ki : float
        The loop's gains.
    settle : float
        Time constants.

    Returns
    -------
    float
        [s].
    """
    return settle * kp / (2.0 * ki) if ki > 0.0 else math.inf


def fit_model(
    fr: FrequencyResponse,
    u: np.ndarray,
    theta: np.ndarray,
    *,
    input: str,
    max_delay: int = 5,
    holdout: float = 0.3,
) -> IdentResult:
    """(3.5) fitted to a closed-loop experiment's frequency response ``fr`` (the indirect
    estimate; time-domain least squares would be biased by the loop, and with the speed held
    a_m w and the offset are one): a_m >= 0, b_m and the delay k (0 .. ``max_delay``) that
    minimise the complex log ratio sum |ln(G_model / G_measured)|^2 over the coherent bins
    (magnitude in nepers and phase in radians alike); standard errors from s^2 (J^T J)^-1.
    Then, the model held, the offset d and the initial state are fitted by linear least squares
    on the positions after the dropped transient, and the held-out fit is computed on the last
    ``holdout`` of them (``rig.identify.estimate.held_out_fit``).

    Parameters
    ----------
    fr : FrequencyResponse
        The frequency response.
    u : np.ndarray
        The command [unit of u].
    theta : np.ndarray
        The position [rad].
    input : str
        "voltage" or "torque".
    max_delay : int, optional
        The most delay tried [samples].
    holdout : float, optional
        The share of the record kept for the fit figure.

    Returns
    -------
    IdentResult
        The model.

    Raises
    ------
    IdentificationError
        If too few bins are coherent to fit it.
    """
    m = _frequency_fit(fr, len(u), max_delay)
    time_fit = _offset_and_fit(
        (m.a, m.b, m.k), u, theta, fr.dt, first=round(fr.dropped / fr.dt), holdout=holdout
    )
    return _result(m, time_fit, dt=fr.dt, samples=len(u), input=input)


@dataclass(frozen=True)
class _ModelFit:
    """(3.5) fitted to a frequency response: a_m, b_m, the delay and their standard errors."""

    a: float  #: [1/s] a_m
    b: float  #: b_m, per unit of the input
    k: int  #: [samples] the delay
    se: tuple[float, float]  #: the standard errors of a_m and b_m


def _frequency_fit(fr: FrequencyResponse, samples: int, max_delay: int) -> _ModelFit:
    """``fit_model``'s model fitted to ``fr``'s coherent bins (a record of ``samples``)."""
    mask = fr.coherent
    if np.count_nonzero(mask) < 3:
        raise IdentificationError(
            f"{np.count_nonzero(mask)} bins of the closed-loop frequency response have a coherence >= "
            f"{COHERENCE_MIN:g}: too few to fit (3.5); raise --amplitude or measure longer"
        )
    fit, k, se = _log_ratio_fit(fr.f[mask], fr.speed[mask], fr.dt, 1.0 / (samples * fr.dt), max_delay)
    return _ModelFit(float(fit.x[0]), float(fit.x[1]), k, (float(se[0]), float(se[1])))


def _result(
    m: _ModelFit, time_fit: tuple[float, float, float, float], *, dt: float, samples: int, input: str
) -> IdentResult:
    """The identified model of ``m`` and the time-domain fit's (offset, fit [%], residual and
    quantisation RMS [rad/s])."""
    d, fit_pct, resid, floor = time_fit
    (a, b), (se_a, se_b) = (m.a, m.b), m.se
    return IdentResult(
        a_m=a,
        b_m=b,
        a_m_stderr=se_a,
        b_m_stderr=se_b,
        a_m_ci95=(a - 1.96 * se_a, a + 1.96 * se_a),
        b_m_ci95=(b - 1.96 * se_b, b + 1.96 * se_b),
        delay_samples=m.k,
        offset=d,
        fit_percent=fit_pct,
        dt=dt,
        samples=samples,
        input=input,
        residual_rms=resid,
        quantisation_rms=floor,
    )


def _log_ratio_fit(
    f: np.ndarray, h: np.ndarray, dt: float, a_start: float, max_delay: int
) -> tuple[Any, int, np.ndarray]:
    """The least-squares fit of (a_m, b_m) for each delay k of 0 .. ``max_delay`` to the speed
    response ``h`` at ``f`` [Hz] (fit_model's criterion), the best of them: (scipy's result, k,
    the standard errors of a_m and b_m from s^2 (J^T J)^-1, inf where J^T J is singular)."""
    import scipy.optimize

    from rig.identify.frequency import model_speed_response

    start = np.array([a_start, float(np.median(np.abs(h) * 2.0 * math.pi * f))])
    best = None
    for k in range(max_delay + 1):

        def residual(p: np.ndarray, k: int = k) -> np.ndarray:
            e = np.log(model_speed_response(p[0], p[1], dt, k, f) / h)
            return np.concatenate([e.real, e.imag])

        trial = scipy.optimize.least_squares(
            residual, start, bounds=([0.0, 0.0], [np.inf, np.inf]), x_scale="jac"
        )
        if best is None or trial.cost < best[0].cost:
            best = (trial, k)
    assert best is not None
    fit, k = best
    s2 = 2.0 * float(fit.cost) / max(1, len(fit.fun) - 2)
    try:
        se = np.sqrt(np.maximum(np.diag(s2 * np.linalg.inv(fit.jac.T @ fit.jac)), 0.0))
    except np.linalg.LinAlgError:
        se = np.full(2, np.inf)
    return fit, k, se


def _offset_and_fit(
    model: tuple[float, float, int],
    u: np.ndarray,
    theta: np.ndarray,
    dt: float,
    *,
    first: int,
    holdout: float,
) -> tuple[float, float, float, float]:
    """(d, held-out fit [%], its residual and the quantisation floor [rad/s]) of (3.5) ``model``
    = (a, b, delay k) from sample ``first`` on: theta = theta_u + d theta_d + theta_0 + w_0 theta_w,
    each part the model's exact response (``simulate_positions``), d, theta_0 and w_0 by least
    squares on the first 1 - ``holdout`` of the samples."""
    from rig.identify.estimate import held_out_fit, simulate_positions

    a, b, k = model
    uu, th = u[first:], theta[first:]
    parts = [
        simulate_positions(np.array(p, dtype=float), uu, dt, k)
        for p in ((a, b, 0, 0, 0), (a, 0, 1, 0, 0), (a, 0, 0, 0, 1))
    ]
    n_fit = int(len(uu) * (1.0 - holdout))
    basis = np.column_stack([parts[1][0], np.ones(len(uu)), parts[2][0]])
    coef, *_ = np.linalg.lstsq(basis[:n_fit], (th - parts[0][0])[:n_fit], rcond=None)
    w_model = parts[0][1] + coef[0] * parts[1][1] + coef[2] * parts[2][1]
    fit, resid, floor = held_out_fit(th, w_model, n_fit, dt)
    return float(coef[0]), fit, resid, floor
