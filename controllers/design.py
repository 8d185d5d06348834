"""Sliding-surface design in the delta domain, eqs. (6.16)-(6.19) of the drives paper.

Pure functions, keyword arguments, a frozen result. The design is the
"general comprehensive method" of the paper: place the poles of conventional
state feedback at [lambda_delta, ..., lambda_delta, 0] (6.17)-(6.18) and take
c_delta = [k_delta 1] pinv([A_delta b_delta]) (6.16), so that c_delta b_delta = 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from controllers.discretize import delta_model

__all__ = ["DTSMDesign", "acker", "design_dtsm", "lambda_delta"]


@dataclass(frozen=True, slots=True)
class DTSMDesign:
    """Delta-domain model and sliding vector of a DTSM controller.

    All vectors are tuples of floats so the design is hashable and JSON-ready.
    """

    dt: float  #: sample period T [s]
    A_delta: tuple[tuple[float, ...], ...]  #: delta-model state matrix (6.9) [1/s]
    b_delta: tuple[float, ...]  #: delta-model input vector (6.9)
    lambda_delta: float  #: desired delta-domain eigenvalue (6.19) [1/s]
    k_delta: tuple[float, ...]  #: state-feedback gain placing [lambda_delta, 0] (6.17)
    c_delta: tuple[float, ...]  #: sliding vector, g_k = c_delta x_k (6.10), (6.16)
    c_delta_A_delta: tuple[float, ...]  #: equivalent-control gain of (6.14)

    @property
    def order(self) -> int:
        """Number of states n."""
        return len(self.b_delta)

    def as_dict(self) -> dict[str, object]:
        """The design as plain data.

        Returns
        -------
        dict
            Lists and floats under the names of the ``rig design dtsm --json`` contract.
        """
        return {
            "A_delta": [list(row) for row in self.A_delta],
            "b_delta": list(self.b_delta),
            "lambda_delta": self.lambda_delta,
            "k_delta": list(self.k_delta),
            "c_delta": list(self.c_delta),
            "c_delta_A_delta": list(self.c_delta_A_delta),
        }


def lambda_delta(lam: float, *, dt: float) -> float:
    """Map a continuous-time eigenvalue to the delta domain, eq. (6.19).

    Parameters
    ----------
    lam : float
        Continuous-time eigenvalue lambda [1/s].
    dt : float
        Sample period T [s].

    Returns
    -------
    float
        lambda_delta = (e^(lambda T) - 1) / T [1/s].
    """
    return math.expm1(lam * dt) / dt


def acker(A: np.ndarray, b: np.ndarray, poles: list[float]) -> np.ndarray:
    """Ackermann's formula: k such that eig(A - b k) = poles (single input).

    Unlike scipy.signal.place_poles it accepts repeated poles, which the design
    [lambda_delta, 0] of (6.18) produces for n = 1 and n = 3.

    Parameters
    ----------
    A : numpy.ndarray, shape (n, n)
        State matrix.
    b : numpy.ndarray, shape (n,)
        Input vector.
    poles : list of float
        The closed-loop eigenvalues wanted, n of them.

    Returns
    -------
    numpy.ndarray, shape (n,)
        The gain row k.

    Raises
    ------
    ValueError
        If (A, b) is not controllable (the controllability matrix is singular).
    """
    n = A.shape[0]
    ctrb = np.empty((n, n))
    col = b.astype(float)
    for i in range(n):
        ctrb[:, i] = col
        col = A @ col
    # Rank test on the normalised controllability matrix: a scale-free check.
    scale = np.linalg.norm(ctrb, axis=0)
    if np.any(scale == 0.0) or np.linalg.matrix_rank(ctrb / scale, tol=1e-10) < n:
        raise ValueError("the pair (A, b) is not controllable: no sliding vector exists")
    coeffs = np.poly(poles)  # [1, a_1, ..., a_n]
    phi = np.zeros((n, n))
    power = np.eye(n)
    for c in coeffs[::-1]:
        phi += c * power
        power = power @ A
    e_n = np.zeros(n)
    e_n[-1] = 1.0
    return np.asarray(np.linalg.solve(ctrb.T, e_n) @ phi)


def design_dtsm(*, A: npt.ArrayLike, b: npt.ArrayLike, dt: float, lam: float) -> DTSMDesign:
    """Design the DTSM sliding vector, eqs. (6.9), (6.16)-(6.19).

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous-time state matrix [1/s] of x' = A x + b (u + f), eq. (6.1).
    b : array_like, shape (n,)
        Continuous-time input vector.
    dt : float
        Sample period T [s], > 0.
    lam : float
        Desired continuous-time eigenvalue lambda [1/s] of the sliding motion,
        < 0. For n = 1 the spectrum is [0] and lambda does not enter c_delta.

    Returns
    -------
    DTSMDesign
        c_delta is scaled so that c_delta b_delta = 1, the assumption of (6.14).

    Raises
    ------
    ValueError
        On dt <= 0, lam >= 0 or non-finite, or an uncontrollable pair.
    """
    lam = float(lam)
    if not math.isfinite(lam) or lam >= 0.0:
        raise ValueError(f"lambda must be a finite eigenvalue < 0 (1/s), got {lam!r}")
    A_delta, b_delta = delta_model(A, b, dt=dt)
    n = A_delta.shape[0]
    lam_d = lambda_delta(lam, dt=dt)
    # (6.18): n-1 poles at lambda_delta and one at 0 (the sliding variable's pole).
    k_delta = acker(A_delta, b_delta, [lam_d] * (n - 1) + [0.0])
    aug = np.column_stack([A_delta, b_delta])
    c_delta = np.append(k_delta, 1.0) @ np.linalg.pinv(aug)  # (6.16)
    cb = float(c_delta @ b_delta)
    if not math.isfinite(cb) or abs(cb - 1.0) > 1e-6:
        raise ValueError(f"design failed: c_delta b_delta = {cb!r}, expected 1")
    return DTSMDesign(
        dt=float(dt),
        A_delta=tuple(tuple(float(v) for v in row) for row in A_delta),
        b_delta=tuple(float(v) for v in b_delta),
        lambda_delta=lam_d,
        k_delta=tuple(float(v) for v in k_delta),
        c_delta=tuple(float(v) for v in c_delta),
        c_delta_A_delta=tuple(float(v) for v in c_delta @ A_delta),
    )
