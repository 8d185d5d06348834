"""Model following, eqs. (3)-(7) of the DISMC paper.

Solve [A B; C 0] [G; H] = [G A_m; C_m] (3) for G (n x n_m) and H (1 x n_m), a
linear system in vec(G) and H, for any n and n_m.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["solve_model_following"]


def solve_model_following(
    *,
    A: npt.ArrayLike,
    B: npt.ArrayLike,
    C: npt.ArrayLike,
    A_m: npt.ArrayLike,
    C_m: npt.ArrayLike,
    tol: float = 1e-9,
) -> tuple[np.ndarray, np.ndarray]:
    """Return (G, H) solving (3); raise ValueError when (3) has no solution.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Discrete plant state matrix of (1).
    B : array_like, shape (n,)
        Plant input vector (single input).
    C : array_like, shape (n,)
        Plant output row.
    A_m : array_like, shape (n_m, n_m)
        Reference-model state matrix of (2).
    C_m : array_like, shape (n_m,)
        Reference-model output row.
    tol : float
        Largest residual of (3) accepted as a solution.

    Returns
    -------
    G : ndarray, shape (n, n_m)
    H : ndarray, shape (n_m,)

    Raises
    ------
    ValueError
        If the shapes do not match or (3) has no solution within ``tol``.
    """
    A_ = np.atleast_2d(np.asarray(A, dtype=float))
    B_ = np.asarray(B, dtype=float).reshape(-1, 1)
    C_ = np.asarray(C, dtype=float).reshape(1, -1)
    Am = np.atleast_2d(np.asarray(A_m, dtype=float))
    Cm = np.asarray(C_m, dtype=float).reshape(-1)
    n, nm = A_.shape[0], Am.shape[0]
    if B_.shape[0] != n or C_.shape[1] != n or Cm.shape[0] != nm:
        raise ValueError(
            f"inconsistent shapes: A {A_.shape}, B {B_.shape}, C {C_.shape}, A_m {Am.shape}, C_m {Cm.shape}"
        )
    eye_m = np.eye(nm)
    # vec(A G - G A_m) = (I kron A - A_m^T kron I) vec(G); vec(B H) = (I kron B) H^T
    top = np.hstack([np.kron(eye_m, A_) - np.kron(Am.T, np.eye(n)), np.kron(eye_m, B_)])
    bottom = np.hstack([np.kron(eye_m, C_), np.zeros((nm, nm))])
    M = np.vstack([top, bottom])
    rhs = np.concatenate([np.zeros(n * nm), Cm])
    sol = np.linalg.lstsq(M, rhs, rcond=None)[0]
    residual = float(np.linalg.norm(M @ sol - rhs))
    if not np.isfinite(residual) or residual > tol:
        raise ValueError(f"the model-following equation (3) has no solution (residual {residual:.3g})")
    G = sol[: n * nm].reshape(nm, n).T
    return G, sol[n * nm :]
