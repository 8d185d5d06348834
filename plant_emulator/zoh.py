"""Exact zero-order-hold stepping of a linear time-invariant model.

The matrix exponential is computed once (scipy); each step is plain-float
multiply-adds on preallocated lists, with no allocation.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
import scipy.linalg

__all__ = ["LinearZOH", "unrolled_step3"]


@functools.lru_cache(maxsize=256)
def _expm(m: bytes, size: int) -> np.ndarray:
    """expm of the ``size`` x ``size`` matrix with the bytes ``m``, once per matrix in a process:
    each run (and each point of a sweep) builds the same few models again."""
    E: np.ndarray = scipy.linalg.expm(np.frombuffer(m).reshape(size, size))
    E.flags.writeable = False
    return E


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

    Raises
    ------
    ValueError
        If dt is not a finite step > 0.
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
        E = _expm((M * dt).tobytes(), n + m)
        self.dt = float(dt)
        self.n, self.m = n, m
        self.A_d = [[float(v) for v in row] for row in E[:n, :n]]
        self.B_d = [[float(v) for v in row] for row in E[:n, n:]]
        self.x = [0.0] * n  #: the state, updated in place by ``step``
        self._tmp = [0.0] * n

    def step(self, u: list[float] | tuple[float, ...]) -> list[float]:
        """Advance one step with a held input.

        Parameters
        ----------
        u : sequence of float
            The input, length m.

        Returns
        -------
        list of float
            The state ``x``, updated in place.
        """
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


def unrolled_step3(zoh: LinearZOH) -> Callable[[list[float], float, float], None]:
    """A step for a 3-state, 2-input ``LinearZOH`` with its 15 coefficients as closure constants.

    The DC servo's step (3.4); its speed against ``LinearZOH.step`` is on docs/benchmarks.md.

    Parameters
    ----------
    zoh : LinearZOH
        The model, n = 3, m = 2.

    Returns
    -------
    callable
        ``step(x, u0, u1)``: x <- A_d x + B_d [u0, u1] in place, no loops, no allocation
        beyond floats.

    Raises
    ------
    ValueError
        If the model is not 3-state, 2-input.
    """
    if (zoh.n, zoh.m) != (3, 2):
        raise ValueError(f"unrolled_step3 needs n = 3, m = 2, got n = {zoh.n}, m = {zoh.m}")
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = zoh.A_d
    (b00, b01), (b10, b11), (b20, b21) = zoh.B_d

    def step(x: list[float], u0: float, u1: float) -> None:
        x0, x1, x2 = x
        x[0] = a00 * x0 + a01 * x1 + a02 * x2 + b00 * u0 + b01 * u1
        x[1] = a10 * x0 + a11 * x1 + a12 * x2 + b10 * u0 + b11 * u1
        x[2] = a20 * x0 + a21 * x1 + a22 * x2 + b20 * u0 + b21 * u1

    return step
