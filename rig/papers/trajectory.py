"""The sampled signals of a closed-loop simulation (``rig.papers.scenarios``), in SI units."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Trajectory"]


@dataclass
class Trajectory:
    """Sampled closed-loop signals, one row per controller sample (SI units)."""

    t: np.ndarray  #: time [s]
    ref: np.ndarray  #: reference of the controlled variable
    y: np.ndarray  #: controlled variable (true, not measured)
    u: np.ndarray  #: control output of the outermost controller called
    g: np.ndarray  #: sliding variable g_k
    extra: dict[str, np.ndarray] = field(default_factory=dict)  #: other signals by name

    @property
    def error(self) -> np.ndarray:
        """Tracking error ref - y."""
        err: np.ndarray = self.ref - self.y
        return err

    def window(self, t0: float, t1: float = math.inf) -> np.ndarray:
        """Boolean mask of the samples with t0 <= t < t1.

        Parameters
        ----------
        t0 : float
            [s].
        t1 : float, optional
            [s].

        Returns
        -------
        np.ndarray
            The mask.
        """
        mask: np.ndarray = (self.t >= t0) & (self.t < t1)
        return mask
