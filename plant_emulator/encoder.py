"""Incremental/absolute rotary encoder: quantisation and Euler-backward speed."""

from __future__ import annotations

import math

__all__ = ["Encoder"]


class Encoder:
    """Quantises the shaft angle to counts and estimates speed by Euler backward.

    Parameters
    ----------
    counts_per_rev : int
        Resolution [counts/rev], > 0 (after quadrature decoding).
    dt : float
        Sampling period [s] of the speed estimate.

    Raises
    ------
    ValueError
        If counts_per_rev is not a positive integer or dt not > 0.
    """

    __slots__ = ("_last", "_rad_per_count", "counts", "counts_per_rev", "dt")

    def __init__(self, counts_per_rev: int, *, dt: float) -> None:
        if int(counts_per_rev) != counts_per_rev or counts_per_rev <= 0:
            raise ValueError(f"counts_per_rev must be a positive integer, got {counts_per_rev!r}")
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be > 0 s, got {dt!r}")
        self.counts_per_rev = int(counts_per_rev)
        self.dt = float(dt)
        self._rad_per_count = 2.0 * math.pi / self.counts_per_rev
        self.counts = 0  #: last count reading
        self._last: int | None = None

    def reset(self) -> None:
        """Forget the previous reading (the next speed estimate is 0)."""
        self._last = None

    def sample(self, theta: float) -> tuple[float, float]:
        """Read the shaft's angle.

        Parameters
        ----------
        theta : float
            The shaft angle [rad].

        Returns
        -------
        tuple of float
            (quantised angle [rad], speed by Euler backward [rad/s]).
        """
        counts = math.floor(theta / self._rad_per_count)
        last = counts if self._last is None else self._last
        self._last = self.counts = counts
        return counts * self._rad_per_count, (counts - last) * self._rad_per_count / self.dt
