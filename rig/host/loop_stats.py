"""The host loop's streaming figures: stage durations and period errors over a window, and the
chattering count, kept as the cycles go (nothing grows with the run's length)."""

from __future__ import annotations

import collections
import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rig.report.metrics import ROUNDING, count_threshold

if TYPE_CHECKING:
    from drivers.base import AxisDriver
    from rig.laws.base import Law

__all__ = ["ChatterCounter", "RunMetrics", "StageTimes", "chatter_threshold"]


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
    #: real time with the host's SYNC, the response's two parts: the drives' answer (the SYNC
    #: sent to their last awaited TPDO) and the host's own time (that TPDO to the RPDOs sent)
    drive_answer: _Window = field(default_factory=_Window)
    host_time: _Window = field(default_factory=_Window)

    def stats(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for name in ("read", "update", "write", "period_error", "response", "drive_answer", "host_time"):
            a = np.abs(np.array(getattr(self, name))) * 1e6
            a = a[np.isfinite(a)]
            if a.size:
                out[f"{name}_median_us"] = float(np.median(a))
                out[f"{name}_p99_us"] = float(np.percentile(a, 99))
                out[f"{name}_max_us"] = float(a.max())
        return out


class ChatterCounter:
    """``rig.report.metrics.chattering_count`` and ``chattering_amplitude`` computed as the samples arrive.

    Only the samples from index ``start`` on (the steady state) count; ``threshold`` is
    ``rig.report.metrics.count_threshold`` for the law and the read axis (``ROUNDING`` at least).
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


def chatter_threshold(law: Law, axis: AxisDriver | None, period: float) -> float:
    """The change of the law's first command that one count of the first read axis's measurement
    can cause (``rig.report.metrics.count_threshold``): the law's ``sensitivity`` times the axis's
    ``quanta``, with the speed quantum at least a count per period [unit of the command]."""
    if axis is None:
        return 0.0
    q_theta, q_omega = axis.quanta()
    return count_threshold(
        law.sensitivity(), position_quantum=q_theta, velocity_quantum=max(q_omega, q_theta / period)
    )


class RunMetrics:
    """The run's tracking error, chattering and per-axis peaks, kept cycle by cycle (nothing
    grows with the run's length): ``add`` each cycle, read at the summary."""

    def __init__(
        self,
        names: Sequence[str],
        measures: Sequence[Collection[str]],
        commanded: Sequence[int],
        *,
        threshold: float,
        steady_from: int,
        command_range: float = math.inf,
    ) -> None:
        """Axes by ``names`` with the quantities each ``measures``; ``commanded``: the axes (indices)
        of a cycle's commands, in order; ``threshold``: the chattering threshold [command unit]
        (``chatter_threshold``), counted from cycle ``steady_from``; ``command_range``: the
        largest increment the first command can make (twice its limit) [command unit]."""
        self.threshold = threshold
        self.command_range = command_range
        self.sq_error = 0.0
        self.max_error = 0.0
        self.chatter = ChatterCounter(threshold, start=steady_from)
        self.peaks = {name: dict.fromkeys(("velocity", "current", "command"), 0.0) for name in names}
        #: per axis, its peaks and the measured quantities whose peak is kept
        self._fields = [
            (self.peaks[name], [f for f in ("velocity", "current") if f in m])
            for name, m in zip(names, measures)
        ]
        self._command_peaks = [self.peaks[names[i]] for i in commanded]

    def add(self, ref: float, y: float, values: Sequence[Any], samples: Sequence[Any]) -> None:
        """One cycle: reference and measurement, its commands (``values``), the axes' feedback."""
        e = ref - y
        self.sq_error += e * e
        e = abs(e)
        if e > self.max_error:  # noqa: PLR1730 - max() without its call, per cycle (NaN alike)
            self.max_error = e
        if values:
            self.chatter.add(abs(values[0]) if isinstance(values[0], complex) else values[0])
        for (peaks, names), fb in zip(self._fields, samples):
            for name in names:
                value = abs(getattr(fb, name))
                if value > peaks[name]:  # noqa: PLR1730 (as above)
                    peaks[name] = value
        for peaks, command in zip(self._command_peaks, values):
            value = abs(command)
            if value > peaks["command"]:  # noqa: PLR1730 (as above)
                peaks["command"] = value

    @property
    def chattering_count(self) -> int | None:
        """The chattering count; None (not measurable) where one count's effect, the threshold, is
        at least ``command_range``: no increment of the command can exceed it."""
        return None if self.threshold >= self.command_range else self.chatter.count

    def rms_error(self, n: int) -> float:
        """The RMS tracking error over ``n`` cycles (NaN for none)."""
        return math.sqrt(self.sq_error / n) if n else math.nan

    def axis_peaks(self) -> dict[str, dict[str, float]]:
        """Per axis, ``max_abs_velocity``, ``max_abs_current``, ``max_abs_command``."""
        return {name: {f"max_abs_{k}": v for k, v in p.items()} for name, p in self.peaks.items()}
