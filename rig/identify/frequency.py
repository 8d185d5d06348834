"""The frequency response from the command u to the speed and the position, and its model's.

Estimate (``frequency_response``): the speed is the backward difference of the measured
position, w_k = (theta_k - theta_k-1) / T, the speed a host computes from an encoder. The
first period (the start from rest) is dropped; the rest is split into Welch segments
(P. D. Welch, "The use of fast Fourier transform for the estimation of power spectra",
IEEE Trans. Audio Electroacoust. 15 (1967) 70-73) of one period each: rectangular and
without overlap when u repeats with that period, else Hann with half overlap. The H1
estimator (J. S. Bendat, A. G. Piersol, "Random Data", 4th ed., Wiley 2010, sec. 9.2),
unbiased by output noise, is

    H1(f) = G_uy(f) / G_uu(f),  gamma^2(f) = |G_uy|^2 / (G_uu G_yy),

with the cross and auto spectral densities and the coherence from ``scipy.signal.csd``,
``welch`` and ``coherence`` (csd(u, y) = E[conj(U) Y]). The position's response follows
exactly: theta = w T / (1 - z^-1).

Closed loop (``r`` given): where the plant cannot run open loop (a torque on a near
integrator runs away), a weak speed loop holds the speed and the excitation r is added to its
command u = C (w_ref - y) + r; u then depends on the measurement noise through C, and H1 is
biased towards -1/C. With r as the instrument, uncorrelated with that noise,

    G(f) = G_ry(f) / G_ru(f) = [G S] / [S]  (S = 1 / (1 + G C)),

the indirect or joint input-output estimate (L. Ljung, "System Identification: Theory for the
User", 2nd ed., Prentice Hall 1999, sec. 13.5; R. Pintelon, J. Schoukens, "System
Identification: A Frequency Domain Approach", 2nd ed., Wiley-IEEE 2012, ch. 2, FRFs measured
in feedback), with the same Welch segments; it needs neither C nor the loop's gains. A bin is
coherent where both gamma^2 from r to u and from r to y are (``coherence`` is the lesser).

The excitation is ``rig.identify.excitations``'s, the model's response ``rig.identify.model_response``'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rig.identify.estimate import IdentificationError
from rig.identify.excitations import (
    FREQUENCY_EXCITATIONS,
    frequency_band,
    period_samples,
    periodic_excitation,
)
from rig.identify.model_response import model_speed_response, model_velocity_response, speed_to_position

__all__ = [
    "COHERENCE_MIN",
    "FREQUENCY_EXCITATIONS",
    "FrequencyResponse",
    "frequency_response",
    "longest_run",
    "model_speed_response",
    "model_velocity_response",
    "period_samples",
    "periodic_excitation",
    "speed_to_position",
]

#: [-] a bin is coherent (the response there is measured, not noise) at this coherence or above
COHERENCE_MIN = 0.9


@dataclass(frozen=True)
class FrequencyResponse:
    """The estimate from u to the speed (and the position) with its coherence; SI, f in Hz."""

    f: np.ndarray  #: [Hz]
    speed: np.ndarray  #: from u to w, complex [(rad/s) per unit of u]
    coherence: np.ndarray  #: gamma^2 [-]
    dt: float  #: [s]
    averages: int  #: Welch segments
    dropped: float  #: [s] of the start's transient, not used
    window: str  #: "boxcar" (periodic excitation, one period a segment) or "hann"
    f_min: float  #: [Hz] the band's lower end
    f_max: float  #: [Hz] its upper end
    #: from u to the speed the drive reported, and its coherence (None: not recorded)
    velocity: np.ndarray | None = None
    velocity_coherence: np.ndarray | None = None  #: the reported speed's coherence (None: none)
    #: "H1" (open loop) or "indirect" (closed loop: G_ry / G_ru, r the excitation)
    method: str = "H1"
    #: the indirect estimate's coherence from r to u (``coherence`` is the lesser of it and r to y)
    input_coherence: np.ndarray | None = None

    @property
    def position(self) -> np.ndarray:
        """From u to theta [rad per unit of u]."""
        out: np.ndarray = self.speed * speed_to_position(self.f, self.dt)
        return out

    @property
    def coherent(self) -> np.ndarray:
        """The bins whose coherence is at least COHERENCE_MIN."""
        out: np.ndarray = self.coherence >= COHERENCE_MIN
        return out

    def coherent_band(self) -> tuple[float, float] | None:
        """[Hz] the longest run of contiguous coherent bins; None when no bin is coherent.

        Returns
        -------
        tuple[float, float] | None
            (first, last) [Hz], or None.
        """
        return longest_run(self.f, self.coherent)

    def deviation(self, model: np.ndarray) -> tuple[float, float]:
        """(worst |dB|, worst |degrees|) of the measured speed response against ``model`` (the
        same bins) over the coherent bins; nan where none is coherent.

        Parameters
        ----------
        model : np.ndarray
            The model's response at the same bins.

        Returns
        -------
        tuple[float, float]
            (worst |dB|, worst |degrees|).
        """
        mask = self.coherent
        if not mask.any():
            return math.nan, math.nan
        ratio = self.speed[mask] / model[mask]
        return float(np.max(np.abs(20.0 * np.log10(np.abs(ratio))))), float(
            np.max(np.abs(np.degrees(np.angle(ratio))))
        )


def longest_run(f: np.ndarray, ok: np.ndarray) -> tuple[float, float] | None:
    """(first, last) of ``f`` over the longest run of contiguous True in ``ok``; None if none.

    Parameters
    ----------
    f : np.ndarray
        [Hz] the bins.
    ok : np.ndarray
        Each bin's flag.

    Returns
    -------
    tuple[float, float] | None
        (first, last), or None.
    """
    best: tuple[int, int] | None = None
    start = None
    for i, v in enumerate([*ok, False]):
        if v and start is None:
            start = i
        elif not v and start is not None:
            if best is None or i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return None if best is None else (float(f[best[0]]), float(f[best[1] - 1]))


def _is_periodic(u: np.ndarray, n: int) -> bool:
    """u repeats with period n samples over the record, but for a dither: the RMS of
    u_k+n - u_k is at most a tenth of u's standard deviation."""
    if len(u) < 2 * n:
        return False
    return bool(np.std(u[n:] - u[:-n]) <= 0.1 * np.std(u))


def frequency_response(
    u: np.ndarray,
    theta: np.ndarray,
    dt: float,
    *,
    f_min: float = 1.0,
    f_max: float | None = None,
    settle: float = 0.0,
    velocity: np.ndarray | None = None,
    r: np.ndarray | None = None,
) -> FrequencyResponse:
    """The response from the command u to the speed (backward differences of the position theta
    [rad]) between f_min and f_max [Hz] (default fs/5); Welch segments of 1/f_min (module doc).
    The first whole periods covering ``settle`` [s] (at least one) are the start's transient and
    are dropped, keeping at least two periods. ``velocity``: the speed the drive reported
    [rad/s] per sample, whose response is estimated too. ``r``: the excitation of a closed-loop
    experiment, the instrument of the indirect estimate G_ry / G_ru (module doc); without it, H1.

    Parameters
    ----------
    u : np.ndarray
        The command.
    theta : np.ndarray
        The position [rad].
    dt : float
        [s] the period.
    f_min, f_max, optional
        [Hz] the band (None: fs/5).
    settle : float, optional
        [s] the start's transient dropped.
    velocity : np.ndarray | None, optional
        The drive's reported speed [rad/s] (None: none).
    r : np.ndarray | None, optional
        The excitation, where the loop was closed (None: open loop).

    Returns
    -------
    FrequencyResponse
        The response.

    Raises
    ------
    IdentificationError
        If the record is shorter than a period, or the input has no power in the band.
    """
    rec = _record(u, theta, dt, f_min=f_min, f_max=f_max, settle=settle, velocity=velocity, r=r)
    return _response(rec, _spectra(rec, dt, indirect=r is not None), dt)


@dataclass(frozen=True)
class _Record:
    """What the spectra are taken of: the band, the segments and the samples kept."""

    lo: float  #: [Hz] the band's low end
    hi: float  #: [Hz] its high end
    n: int  #: samples in a segment (one period of ``lo``)
    periodic: bool  #: x repeats every n samples (rectangular segments without overlap)
    drop: int  #: samples dropped as the start's transient
    u: np.ndarray  #: the command kept
    x: np.ndarray  #: what the spectra are taken against, kept (u, or r in closed loop)
    w: np.ndarray  #: [rad/s] the speed from the positions, kept
    v: np.ndarray | None  #: [rad/s] the speed the drive reported, kept (None: none)


def _record(
    u: np.ndarray,
    theta: np.ndarray,
    dt: float,
    *,
    f_min: float,
    f_max: float | None,
    settle: float,
    velocity: np.ndarray | None,
    r: np.ndarray | None,
) -> _Record:
    """``frequency_response``'s record: the band, checked long enough, the transient dropped."""
    u, theta = np.asarray(u, dtype=float), np.asarray(theta, dtype=float)
    lo, hi = frequency_band(f_min, f_max, dt)
    n = period_samples(lo, dt)
    _enough(len(u), n, dt, lo)
    x = u if r is None else np.asarray(r, dtype=float)  # what the spectra are taken against
    periodic = _is_periodic(x, n)
    drop, (uu, xx, w, v) = _kept(u, x, theta, velocity, n=n, dt=dt, settle=settle, periodic=periodic)
    return _Record(lo, hi, n, periodic, drop, uu, xx, w, v)


@dataclass(frozen=True)
class _Spectra:
    """A record's Welch estimates against x, per frequency bin."""

    f: np.ndarray  #: [Hz] the bins
    g_xx: np.ndarray  #: x's auto spectrum
    g_xu: np.ndarray  #: the cross spectrum x -> u
    g_xy: np.ndarray  #: the cross spectrum x -> w
    g_v: np.ndarray | None  #: the cross spectrum x -> v (None: no v)
    gamma2: np.ndarray  #: the coherence x -> w
    gamma2_v: np.ndarray | None  #: the coherence x -> v (None: no v)
    gamma2_u: np.ndarray | None  #: the coherence x -> u (None: open loop, x is u)
    window: str  #: the segments' window
    overlap: int  #: samples the segments overlap


def _spectra(rec: _Record, dt: float, *, indirect: bool) -> _Spectra:
    """``rec``'s spectra and coherences against x; ``indirect``: x is the closed loop's r."""
    import scipy.signal

    window, overlap = ("boxcar", 0) if rec.periodic else ("hann", rec.n // 2)
    kw = {"fs": 1.0 / dt, "window": window, "nperseg": rec.n, "noverlap": overlap, "detrend": "constant"}
    f, g_xx = scipy.signal.welch(rec.x, **kw)
    _, g_xu = scipy.signal.csd(rec.x, rec.u, **kw)
    _, g_xy = scipy.signal.csd(rec.x, rec.w, **kw)
    g_v = None if rec.v is None else scipy.signal.csd(rec.x, rec.v, **kw)[1]
    with np.errstate(divide="ignore", invalid="ignore"):  # bins without power: nan, not kept
        gamma2 = scipy.signal.coherence(rec.x, rec.w, **kw)[1]
        gamma2_v = None if rec.v is None else scipy.signal.coherence(rec.x, rec.v, **kw)[1]
        gamma2_u = scipy.signal.coherence(rec.x, rec.u, **kw)[1] if indirect else None
    return _Spectra(f, g_xx, g_xu, g_xy, g_v, gamma2, gamma2_v, gamma2_u, window, overlap)


def _response(rec: _Record, sp: _Spectra, dt: float) -> FrequencyResponse:
    """The response in ``rec``'s band from ``sp``: H1, or the indirect estimate where ``sp`` has
    the coherence x -> u (x is r)."""
    indirect = sp.gamma2_u is not None
    # H1 divides by the input's auto spectrum G_uu, the indirect estimate by G_ru
    g_in = sp.g_xu if indirect else sp.g_xx
    band = (sp.f >= rec.lo - 1e-9) & (sp.f <= rec.hi + 1e-9) & (sp.g_xx > 0.0)
    if not band.any():
        raise IdentificationError(f"the input has no power between {rec.lo:g} and {rec.hi:g} Hz")
    gamma2, gamma2_v = sp.gamma2, sp.gamma2_v
    if sp.gamma2_u is not None:  # a bin is as good as the worse of r -> u and r -> y
        gamma2 = np.minimum(gamma2, sp.gamma2_u)
        gamma2_v = None if gamma2_v is None else np.minimum(gamma2_v, sp.gamma2_u)
    return FrequencyResponse(
        f=sp.f[band],
        speed=sp.g_xy[band] / g_in[band],
        coherence=gamma2[band],
        dt=dt,
        averages=1 + (len(rec.u) - rec.n) // (rec.n - sp.overlap),
        dropped=rec.drop * dt,
        window=sp.window,
        f_min=rec.lo,
        f_max=rec.hi,
        velocity=None if sp.g_v is None else sp.g_v[band] / g_in[band],
        velocity_coherence=None if gamma2_v is None else gamma2_v[band],
        method="indirect" if indirect else "H1",
        input_coherence=None if sp.gamma2_u is None else sp.gamma2_u[band],
    )


def _enough(samples: int, n: int, dt: float, f_min: float) -> None:
    """IdentificationError unless ``samples`` cover three periods of ``n`` (the first dropped)."""
    if samples < 3 * n + 1:
        raise IdentificationError(
            f"{samples} samples ({samples * dt:g} s) for a frequency response from {f_min:g} Hz: record at "
            f"least three periods of 1/f_min ({3 * n * dt:g} s; the first is the start's transient)"
        )


def _kept(
    u: np.ndarray,
    x: np.ndarray,
    theta: np.ndarray,
    velocity: np.ndarray | None,
    *,
    n: int,
    dt: float,
    settle: float,
    periodic: bool,
) -> tuple[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]]:
    """The samples dropped as the start's transient (whole periods of ``n`` covering ``settle``
    [s], at least one, keeping two), and what is kept of u, x, the speed w_k = (theta_k -
    theta_(k-1))/T (paired with u_k) and ``velocity``; whole periods only where ``periodic``."""
    drop = n * min(max(1, math.ceil(settle / (n * dt))), (len(u) - 1) // n - 2)
    w = np.diff(theta[drop - 1 :]) / dt
    uu, xx = u[drop:], x[drop:]
    v = None if velocity is None else np.asarray(velocity, dtype=float)[drop:]
    if periodic:  # whole periods only
        keep = (len(uu) // n) * n
        uu, xx, w = uu[:keep], xx[:keep], w[:keep]
        v = None if v is None else v[:keep]
    return drop, (uu, xx, w, v)


#: [time constants 1/a_m] the start's transient dropped from a frequency response (e^-7 < 0.1 %)
SETTLE = 7.0
