"""The host loop's streaming figures: stage durations and period errors over a window, and the
chattering count, kept as the cycles go (nothing grows with the run's length)."""

from __future__ import annotations

import collections
from dataclasses import dataclass, field

import numpy as np

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
    """``rig.metrics.chattering_count`` computed as the samples arrive."""

    def __init__(self, tol: float) -> None:
        self.tol = tol
        self.count = 0
        self._last: float | None = None
        self._sign = 0.0

    def add(self, u: float) -> None:
        if self._last is not None:
            du = u - self._last
            if abs(du) > self.tol:
                sign = 1.0 if du > 0 else -1.0
                if self._sign and sign != self._sign:
                    self.count += 1
                self._sign = sign
        self._last = u
