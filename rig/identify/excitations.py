"""The excitation of an experiment.

In the time domain (``excitation``, ``rig.identify.estimate``): u = u_0 + A prbs(t) (or steps),
with u_0 keeping the speed of one sign so Coulomb friction is a constant offset, the PRBS clock a
few times shorter than 1/a_m.

For the frequency response (``periodic_excitation``, ``rig.identify.frequency``): u = u_0 + A x(t),
x periodic with period N T, N = round(1 / (f_min T)), so every bin of a Welch segment of one period
is a line of the excitation (no leakage with a rectangular window):

- ``multisine``: equal lines at every bin from f_min to f_max with Schroeder's phases
  phi_k = -pi k (k - 1) / K (M. R. Schroeder, "Synthesis of low-peak-factor signals and
  binary sequences with low autocorrelation", IEEE Trans. Inf. Theory 16 (1970) 85-89),
  synthesised by an inverse real FFT and scaled to a peak of 1;
- ``chirp``: a logarithmic sweep from f_min to f_max over one period
  (``scipy.signal.chirp``), repeated.
"""

from __future__ import annotations

import math

import numpy as np

from rig.identify.errors import IdentificationError

__all__ = [
    "FREQUENCY_EXCITATIONS",
    "F_MAX_FRACTION",
    "excitation",
    "frequency_band",
    "period_samples",
    "periodic_excitation",
]

FREQUENCY_EXCITATIONS = ("chirp", "multisine")
#: the default upper frequency, a fraction of the sample rate
F_MAX_FRACTION = 0.2


def period_samples(f_min: float, dt: float) -> int:
    """N = round(1 / (f_min T)): the excitation's period and the Welch segment [samples].

    Parameters
    ----------
    f_min : float
        [Hz] > 0.
    dt : float
        [s] the period T.

    Returns
    -------
    int
        N.

    Raises
    ------
    IdentificationError
        If ``f_min`` is not > 0 or gives too few samples.
    """
    if not (math.isfinite(f_min) and f_min > 0.0):
        raise IdentificationError(f"f_min = {f_min!r} Hz: expected a frequency > 0")
    return max(8, round(1.0 / (f_min * dt)))


def frequency_band(f_min: float, f_max: float | None, dt: float) -> tuple[float, float]:
    """The band [Hz] an experiment excites and measures: f_min to f_max (None: ``F_MAX_FRACTION``
    of the sample rate), within the Nyquist frequency.

    Parameters
    ----------
    f_min : float
        [Hz] the lowest line.
    f_max : float | None
        [Hz] the highest (None: ``F_MAX_FRACTION`` / ``dt``).
    dt : float
        [s] the period T.

    Returns
    -------
    tuple[float, float]
        (f_min, f_max) [Hz].

    Raises
    ------
    IdentificationError
        If f_max is not above f_min or above fs/2.
    """
    fs = 1.0 / dt
    hi = F_MAX_FRACTION * fs if f_max is None else f_max
    if not (math.isfinite(hi) and f_min < hi <= fs / 2.0):
        raise IdentificationError(
            f"f_max = {hi!r} Hz: expected f_min ({f_min:g} Hz) < f_max <= fs/2 = {fs / 2.0:g} Hz"
        )
    return f_min, hi


def periodic_excitation(
    kind: str,
    *,
    u0: float,
    amplitude: float,
    dt: float,
    duration: float,
    f_min: float = 1.0,
    f_max: float | None = None,
) -> np.ndarray:
    """u_k = u0 + amplitude x_k [unit of u], x a ``multisine`` or ``chirp`` of period
    1/f_min (rounded to samples) between f_min and f_max [Hz] (default fs/5), peak 1.

    Parameters
    ----------
    kind : str
        "multisine" or "chirp".
    u0 : float
        The mean [unit of u].
    amplitude : float
        About it [unit of u].
    dt : float
        [s] the period T.
    duration : float
        [s].
    f_min, f_max, optional
        [Hz] the band (None: fs/5).

    Returns
    -------
    np.ndarray
        u_k.

    Raises
    ------
    ValueError
        If ``kind`` is neither.
    IdentificationError
        If the band holds no frequency line.
    """
    import scipy.signal

    n_period = period_samples(f_min, dt)
    lo, hi = frequency_band(f_min, f_max, dt)
    if kind == "multisine":
        x = _multisine(n_period, dt, lo, hi)
    elif kind == "chirp":
        t = np.arange(n_period) * dt
        x = scipy.signal.chirp(t, f0=lo, t1=n_period * dt, f1=hi, method="logarithmic")
    else:
        raise ValueError(f"excitation {kind!r}: expected one of {', '.join(FREQUENCY_EXCITATIONS)}")
    x = x / float(np.max(np.abs(x)))
    n = round(duration / dt)
    out: np.ndarray = u0 + amplitude * np.resize(x, n)
    return out


def _multisine(n_period: int, dt: float, lo: float, hi: float) -> np.ndarray:
    """One period (``n_period`` samples of ``dt`` [s]) of equal lines from ``lo`` to ``hi`` [Hz],
    Schroeder's phases."""
    k = np.arange(n_period // 2 + 1)
    f = k / (n_period * dt)
    lines = k[(f >= lo) & (f <= hi)]
    if len(lines) == 0:
        raise IdentificationError(f"no frequency line between {lo:g} and {hi:g} Hz at T = {dt:g} s")
    spectrum = np.zeros(len(k), dtype=complex)
    j = np.arange(1, len(lines) + 1)
    spectrum[lines] = np.exp(-1j * math.pi * j * (j - 1) / len(lines))  # Schroeder
    x: np.ndarray = np.fft.irfft(spectrum, n_period)
    return x


def excitation(
    kind: str, *, u0: float, amplitude: float, clock: float, dt: float, duration: float, seed: int = 0
) -> np.ndarray:
    """The input sequence u_k [V]: ``prbs`` (a maximum-length-like random binary signal held
    for ``clock`` seconds per bit) or ``steps`` (alternating +-amplitude every 4 clocks).

    Parameters
    ----------
    kind : str
        "prbs" or "steps".
    u0 : float
        [V] the mean.
    amplitude : float
        [V] about it.
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
        u_k [V].

    Raises
    ------
    ValueError
        If ``kind`` is neither.
    """
    n = round(duration / dt)
    per_bit = max(1, round(clock / dt))
    bits = math.ceil(n / per_bit)
    if kind == "prbs":
        rng = np.random.default_rng(seed)
        levels = rng.integers(0, 2, bits) * 2 - 1
    elif kind == "steps":
        levels = np.array([1 if (i // 4) % 2 == 0 else -1 for i in range(bits)])
    else:
        raise ValueError(f"excitation {kind!r}: expected prbs or steps")
    out: np.ndarray = u0 + amplitude * np.repeat(levels.astype(float), per_bit)[:n]
    return out
