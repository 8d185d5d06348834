"""DSMC and discrete integral SMC with and without anti-windup (the DISMC paper).

One class, three laws sharing the reaching law (9)-(10) and the disturbance
estimate (13); ``variant`` selects:

- ``"dsmc"``: sigma = S (x - x_m) (8), control (12);
- ``"dismc"``: sigma = S z - S e^(-beta k) z(0) - eps (23), control (34) plus H x_m (4);
- ``"dismc-aw"``: sigma = S z - S e^(-beta k) z(0) - alpha(k) eps (36), alpha(k) =
  exp(-eps(k)^2 / mu) (36c), control (45) plus H x_m (4).

z = x - G x_m (5); eps(k+1) = eps(k) + S (A + B K) z(k) (23b)/(36b), eps(0) = 0.
For a single input S d_hat is a scalar and S S^+ = 1, so (13) is carried as
S d_hat(k) = S d_hat(k-1) + sigma(k) - phi sigma(k-1) + eta sat(sigma(k-1)/varphi),
with d_hat(0) = 0. z(0) is the first state seen after ``reset``.
The step is plain floats; n is any size, each product a short loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

__all__ = ["DISMC", "DISMCParams", "dismc_lqr_gain", "lmi_28_holds"]

Variant = Literal["dsmc", "dismc", "dismc-aw"]
_VARIANTS = ("dsmc", "dismc", "dismc-aw")


def _eq_system(A: npt.ArrayLike, B: npt.ArrayLike, S: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """A_eq = A + B (SB)^-1 S and B_eq = -B of (28)."""
    A_ = np.atleast_2d(np.asarray(A, dtype=float))
    B_ = np.asarray(B, dtype=float).ravel()
    S_ = np.asarray(S, dtype=float).ravel()
    return A_ + np.outer(B_, S_) / float(S_ @ B_), -B_


def dismc_lqr_gain(
    *, A: npt.ArrayLike, B: npt.ArrayLike, S: npt.ArrayLike, Q: npt.ArrayLike, R: float
) -> np.ndarray:
    """The DISMC feedback gain by LQR on the equivalent system (28), eqs. (31)-(32).

    Parameters
    ----------
    A : array_like, shape (n, n)
        Plant state matrix of (1).
    B : array_like, shape (n,)
        Plant input vector of (1).
    S : array_like, shape (n,)
        Sliding matrix, SB != 0.
    Q : array_like, shape (n, n)
        State weight of the LQR cost.
    R : float
        Input weight, > 0.

    Returns
    -------
    numpy.ndarray, shape (n,)
        K = (B_eq^T P B_eq + R)^-1 B_eq^T P A_eq (31), P from the DARE (32) (scipy).

    Raises
    ------
    ValueError
        If R is not > 0.
    """
    import scipy.linalg

    A_eq, B_eq = _eq_system(A, B, S)
    if not R > 0.0:
        raise ValueError(f"R must be > 0, got {R!r}")
    P = scipy.linalg.solve_discrete_are(
        A_eq, B_eq.reshape(-1, 1), np.asarray(Q, dtype=float), np.array([[float(R)]])
    )
    return np.asarray((B_eq @ P @ A_eq) / (B_eq @ P @ B_eq + R))


def lmi_28_holds(
    *, A: npt.ArrayLike, B: npt.ArrayLike, S: npt.ArrayLike, X: npt.ArrayLike, W: npt.ArrayLike
) -> bool:
    """Check the LMI (28) for a candidate X, W.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Plant state matrix of (1).
    B : array_like, shape (n,)
        Plant input vector of (1).
    S : array_like, shape (n,)
        Sliding matrix, SB != 0.
    X : array_like, shape (n, n)
        The symmetric matrix of (28).
    W : array_like, shape (n,)
        The gain variable of (28) (K = W X^-1).

    Returns
    -------
    bool
        True when X > 0 and [[-X, (A_eq X - B_eq W)^T], [A_eq X - B_eq W, -X]] < 0.
    """
    A_eq, B_eq = _eq_system(A, B, S)
    X_ = np.asarray(X, dtype=float)
    off = A_eq @ X_ - np.outer(B_eq, np.asarray(W, dtype=float).ravel())
    M = np.block([[-X_, off.T], [off, -X_]])
    return bool(np.all(np.linalg.eigvalsh(X_) > 0) and np.all(np.linalg.eigvalsh((M + M.T) / 2) < 0))


def _row(v: npt.ArrayLike) -> tuple[float, ...]:
    return tuple(float(x) for x in np.asarray(v, dtype=float).ravel())


def _mat(M: npt.ArrayLike) -> tuple[tuple[float, ...], ...]:
    return tuple(_row(r) for r in np.atleast_2d(np.asarray(M, dtype=float)))


@dataclass(frozen=True, slots=True)
class DISMCParams:
    """Plant (1), model following (3) and the design parameters (51)-(53) of the DISMC paper.

    Raises
    ------
    ValueError
        If the variant is unknown, the shapes of A, S and K do not match B, SB = 0, or a design
        parameter is out of its range.
    """

    A: tuple[tuple[float, ...], ...]  #: plant state matrix of (1)
    B: tuple[float, ...]  #: plant input vector of (1)
    A_m: tuple[tuple[float, ...], ...]  #: reference-model matrix of (2)
    G: tuple[tuple[float, ...], ...]  #: model-following G of (3); n x n_m
    H: tuple[float, ...]  #: model-following H of (3); length n_m
    S: tuple[float, ...]  #: sliding matrix, SB != 0 (8)
    phi: float  #: reaching-law factor, 0 < phi < 1 (9)
    eta: float  #: reaching-law gain, > 0 (9)
    varphi: float  #: boundary-layer width, > 0 (10)
    K: tuple[float, ...] = ()  #: feedback gain of (23b)/(34); empty for DSMC
    beta: float = 0.9  #: decay of the reaching-phase term, > 0 (23a)
    mu: float = 1.13  #: width of the anti-windup gain alpha, > 0 (36c)
    variant: Variant = "dismc"  #: "dsmc", "dismc" or "dismc-aw"

    def __post_init__(self) -> None:
        n = len(self.B)
        if self.variant not in _VARIANTS:
            raise ValueError(f"variant must be one of {_VARIANTS}, got {self.variant!r}")
        if len(self.A) != n or any(len(r) != n for r in self.A) or len(self.S) != n:
            raise ValueError(f"A must be {n}x{n} and S of length {n} to match B")
        if self.variant != "dsmc" and len(self.K) != n:
            raise ValueError(f"{self.variant} needs a feedback gain K of length {n}, got {self.K!r}")
        sb = sum(s * b for s, b in zip(self.S, self.B))
        checks = {
            "SB": sb != 0.0,
            "phi": 0.0 < self.phi < 1.0,
            "eta": self.eta > 0.0,
            "varphi": self.varphi > 0.0,
            "beta": self.beta > 0.0,
            "mu": self.mu > 0.0,
        }
        for name, ok in checks.items():
            if not ok:
                raise ValueError(f"DISMC parameter {name} is out of range")

    @classmethod
    def build(
        cls,
        *,
        A: npt.ArrayLike,
        B: npt.ArrayLike,
        A_m: npt.ArrayLike,
        G: npt.ArrayLike,
        H: npt.ArrayLike,
        S: npt.ArrayLike,
        K: npt.ArrayLike = (),
        **kw: float | str,
    ) -> DISMCParams:
        """Build from array-likes.

        Parameters
        ----------
        A, B, A_m, G, H, S, K : array_like
            The fields of the same names, as arrays (K empty for DSMC).
        **kw : float or str
            The scalar fields (``phi``, ``eta``, ``varphi``, ``beta``, ``mu``, ``variant``).

        Returns
        -------
        DISMCParams
            The parameters, each array a tuple of floats.
        """
        return cls(A=_mat(A), B=_row(B), A_m=_mat(A_m), G=_mat(G), H=_row(H), S=_row(S), K=_row(K), **kw)  # type: ignore[arg-type]


@dataclass
class DISMC:
    """The DSMC / DISMC / DISMC-AW law; ``step(x, x_m)`` returns u(k) = H x_m + v (4).

    Parameters
    ----------
    params : DISMCParams
        The plant, the model following and the design.
    """

    params: DISMCParams
    sigma: float = field(default=0.0, init=False)  #: sliding function sigma(k)
    eps: float = field(default=0.0, init=False)  #: integrative portion eps(k)

    def __post_init__(self) -> None:
        p = self.params
        A, B, S = np.array(p.A), np.array(p.B), np.array(p.S)
        self._inv_sb = 1.0 / float(S @ B)
        self._SA = _row(S @ A)
        self._SAm = _row(S @ np.array(p.A_m)) if len(p.A_m) == len(p.B) else ()
        self._SG = _row(S @ np.array(p.G))
        self._G = p.G
        self._H = p.H
        K = np.array(p.K) if p.K else np.zeros(len(p.B))
        self._K = _row(K)
        self._SABK = _row(S @ (A + np.outer(B, K)))
        self._variant = _VARIANTS.index(p.variant)
        self._decay = math.exp(-p.beta)
        self.reset()

    def reset(self) -> None:
        """Restore the initial state; the next x, x_m define z(0)."""
        self.sigma = self.eps = 0.0
        self._sd_hat = 0.0
        self._sigma_prev = math.nan
        self._sz0_exp = math.nan  # S z(0) e^(-beta k)
        self._reach_prev = 0.0

    def _sat(self, s: float) -> float:
        r = s / self.params.varphi
        return 1.0 if r > 1.0 else (-1.0 if r < -1.0 else r)

    def step(self, x: tuple[float, ...] | list[float], x_m: tuple[float, ...] | list[float]) -> float:
        """One update from the plant state and the model state.

        Parameters
        ----------
        x : sequence of float
            The plant state x(k).
        x_m : sequence of float
            The reference model's state x_m(k).

        Returns
        -------
        float
            The control u(k) = H x_m + v (4), v by (12), (34) or (45).
        """
        p = self.params
        z = [xi - sum(g * xm for g, xm in zip(row, x_m)) for xi, row in zip(x, self._G)]
        sz = sum(s * zi for s, zi in zip(p.S, z))
        if self._sz0_exp != self._sz0_exp:  # first sample: z(0)
            self._sz0_exp = sz
        variant = self._variant
        if variant == 0:  # (8)
            sigma = sum(s * (xi - xm) for s, xi, xm in zip(p.S, x, x_m))
        elif variant == 1:  # (23a)
            sigma = sz - self._sz0_exp - self.eps
        else:  # (36a), (36c)
            sigma = sz - self._sz0_exp - math.exp(-self.eps * self.eps / p.mu) * self.eps
        if self._sigma_prev == self._sigma_prev:  # (13), from k = 1 on
            self._sd_hat += sigma - self._reach_prev
        self._sigma_prev = sigma
        self.sigma = sigma
        reach = p.phi * sigma - p.eta * self._sat(sigma)  # (9)
        self._reach_prev = reach
        inv_sb = self._inv_sb
        if variant == 0:  # (12)
            sax = sum(a * xi for a, xi in zip(self._SA, x))
            samxm = sum(a * xm for a, xm in zip(self._SAm, x_m))
            return inv_sb * (reach - sax - self._sd_hat + samxm)
        self._sz0_exp *= self._decay  # now S z(0) e^(-beta (k+1))
        eps_next = self.eps + sum(a * zi for a, zi in zip(self._SABK, z))  # (23b)/(36b)
        if variant == 1:  # (34)
            v = inv_sb * (reach - self._sd_hat + self._sz0_exp + self.eps)
            v += sum(k * zi for k, zi in zip(self._K, z))
        else:  # (45)
            saz = sum(a * zi for a, zi in zip(self._SA, z))
            alpha_next = math.exp(-eps_next * eps_next / p.mu)
            v = inv_sb * (reach - saz - self._sd_hat + self._sz0_exp + alpha_next * eps_next)
        self.eps = eps_next
        return sum(h * xm for h, xm in zip(self._H, x_m)) + v  # (4)
