"""Exact zero-order-hold stepping of a linear time-invariant model.

The matrix exponential is computed once (scipy); each step is plain-float
multiply-adds on preallocated lists, with no allocation.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg

__all__ = ["LinearZOH"]


class LinearZOH:
    """x_{k+1} = A_d x_k + B_d u_k with A_d = e^(A dt), B_d = int_0^dt e^(A s) ds B.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous-time state matrix [1/s].
    B : array_like, shape (n, m)
        Continuous-time input matrix.
    dt : float
        Step [s], > 0; the inputs are held constant over it.
    """

    __slots__ = ("A_d", "B_d", "_tmp", "dt", "m", "n", "x")

    def __init__(self, A: object, B: object, dt: float) -> None:
        A_ = np.atleast_2d(np.asarray(A, dtype=float))
        B_ = np.asarray(B, dtype=float).reshape(A_.shape[0], -1)
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a finite number > 0 s, got {dt!r}")
        n, m = B_.shape
        M = np.zeros((n + m, n + m))
        M[:n, :n] = A_
        M[:n, n:] = B_
        E = scipy.linalg.expm(M * dt)
        self.dt = float(dt)
        self.n, self.m = n, m
        self.A_d = [[float(v) for v in row] for row in E[:n, :n]]
        self.B_d = [[float(v) for v in row] for row in E[:n, n:]]
        self.x = [0.0] * n  #: the state, updated in place by ``step``
        self._tmp = [0.0] * n

    def step(self, u: list[float] | tuple[float, ...]) -> list[float]:
        """Advance one step with the held input u (length m); returns the state list."""
        x, tmp = self.x, self._tmp
        for i in range(self.n):
            acc = 0.0
            for a, xj in zip(self.A_d[i], x):
                acc += a * xj
            for b, uj in zip(self.B_d[i], u):
                acc += b * uj
            tmp[i] = acc
        x[:] = tmp
        return x
