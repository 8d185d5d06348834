"""Zero-order-hold discretisation and the delta model, eq. (6.9) of the drives paper.

Pure functions: matrices in, matrices out. ``dt`` is the sample period T in seconds.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["delta_model", "zoh"]


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0.0:
        raise ValueError(f"sample period dt must be a finite number > 0 s, got {dt!r}")
    return dt


def _as_system(A: npt.ArrayLike, B: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    A_ = np.atleast_2d(np.asarray(A, dtype=float))
    n = A_.shape[0]
    if A_.ndim != 2 or A_.shape != (n, n):
        raise ValueError(f"A must be square, got shape {A_.shape}")
    B_ = np.asarray(B, dtype=float)
    if B_.ndim == 1 and B_.shape[0] == n:
        B_ = B_.reshape(n, 1)
    if B_.ndim != 2 or B_.shape[0] != n:
        raise ValueError(f"B must have {n} rows to match A, got shape {B_.shape}")
    if not (np.all(np.isfinite(A_)) and np.all(np.isfinite(B_))):
        raise ValueError("A and B must be finite")
    return A_, B_


def zoh(A: npt.ArrayLike, B: npt.ArrayLike, *, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH discretisation: x_{k+1} = A_d x_k + B_d u_k.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous-time state matrix [1/s].
    B : array_like, shape (n,) or (n, m)
        Continuous-time input matrix.
    dt : float
        Sample period T [s], > 0.

    Returns
    -------
    A_d, B_d : ndarray
        A_d = e^(A T); B_d = integral_0^T e^(A s) ds B, both from one matrix
        exponential of the augmented matrix [[A, B], [0, 0]] T. B_d keeps the
        shape B was given in.
    """
    import scipy.linalg

    dt = _check_dt(dt)
    A_, B_ = _as_system(A, B)
    n, m = B_.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A_
    M[:n, n:] = B_
    E = scipy.linalg.expm(M * dt)
    return E[:n, :n], E[:n, n:]


def delta_model(A: npt.ArrayLike, b: npt.ArrayLike, *, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Delta-operator model, eq. (6.9): A_delta = (A_d - I)/T, b_delta = b_d/T.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous-time state matrix [1/s].
    b : array_like, shape (n,)
        Continuous-time input vector.
    dt : float
        Sample period T [s], > 0.

    Returns
    -------
    A_delta : ndarray, shape (n, n)
    b_delta : ndarray, shape (n,)
    """
    A_d, b_d = zoh(A, np.ravel(np.asarray(b, dtype=float)), dt=dt)
    n = A_d.shape[0]
    return (A_d - np.eye(n)) / dt, b_d[:, 0] / dt
