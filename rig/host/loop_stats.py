"""The host loop's streaming figures: stage durations and period errors over a window, and the
chattering count, kept as the cycles go (nothing grows with the run's length)."""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field

import numpy as np

from rig.metrics import ROUNDING

__all__ = ["ChatterCounter", "StageTimes"]


class _Window(collections.deque):  # type: ignore[type-arg]
    """The last ``WINDOW`` values: timing statistics without growing memory on long runs."""

    WINDOW = 20_000

    def __init__(self) -> None:
        super().__init__(maxlen=self.WINDOW)


@dataclass
class StageTimes:
    """Per-stage durations [s] of the last 20,000 cycles (read, update, write) and period errors."""

    read: _Window = field(default_factory=_Window)
    update: _Window = field(default_factory=_Window)
    write: _Window = field(default_factory=_Window)
    period_error: _Window = field(default_factory=_Window)
    #: real time: a read axis's newest TPDO on the bus to the RPDOs sent in answer
    response: _Window = field(default_factory=_Window)

    def stats(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for name in ("read", "update", "write", "period_error", "response"):
            a = np.abs(np.array(getattr(self, name))) * 1e6
            if a.size:
                out[f"{name}_median_us"] = float(np.median(a))
                out[f"{name}_p99_us"] = float(np.percentile(a, 99))
                out[f"{name}_max_us"] = float(a.max())
        return out


class ChatterCounter:
    """``rig.metrics.chattering_count`` and ``chattering_amplitude`` computed as the samples arrive.

    Only the samples from index ``start`` on (the steady state) count; ``threshold`` is
    ``rig.metrics.count_threshold`` for the law and the read axis (``ROUNDING`` at least).
    """

    def __init__(self, threshold: float, *, start: int = 0) -> None:
        self.threshold = max(threshold, ROUNDING)
        self.start = start  #: the first sample of the steady state
        self.count = 0
        self._n = 0
        self._sq = 0.0
        self._increments = 0
        self._last: float | None = None
        self._sign = 0.0

    @property
    def amplitude(self) -> float:
        """RMS of the command increment over the steady state [unit of u]; NaN before two samples."""
        return math.sqrt(self._sq / self._increments) if self._increments else math.nan

    def add(self, u: float) -> None:
        n = self._n
        self._n = n + 1
        if n < self.start:
            return
        if self._last is not None:
            du = u - self._last
            self._sq += du * du
            self._increments += 1
            if abs(du) > self.threshold:
                sign = 1.0 if du > 0 else -1.0
                if self._sign and sign != self._sign:
                    self.count += 1
                self._sign = sign
        self._last = u
