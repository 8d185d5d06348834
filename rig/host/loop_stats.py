"""The host loop's streaming figures: stage durations and period errors over a window, the
tracking error, the peaks and the chattering (``rig.host.chatter``), kept as the cycles go
(nothing grows with the run's length)."""

from __future__ import annotations

import collections
import math
import time
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rig.host.chatter import RunChatter
from rig.laws.base import SIGN_LAW

if TYPE_CHECKING:
    from drivers.base import AxisDriver
    from rig.host.control import Wiring
    from rig.laws.base import Law

__all__ = ["CycleTimes", "RunMetrics", "StageTimes", "run_metrics"]


class _Window(collections.deque):  # type: ignore[type-arg]
    """The last ``WINDOW`` values: timing statistics without growing memory on long runs."""

    WINDOW = 20_000

    def __init__(self) -> None:
        super().__init__(maxlen=self.WINDOW)


@dataclass
class StageTimes:
    """Per-stage durations [s] of the last 20,000 cycles (read, update, write) and period errors."""

    read: _Window = field(default_factory=_Window)  #: reading every axis's feedback
    update: _Window = field(default_factory=_Window)  #: the law's step and the commands' checks
    write: _Window = field(default_factory=_Window)  #: sending the commands
    #: real time: a tick's start against its deadline (or the bus's SYNC against its period)
    period_error: _Window = field(default_factory=_Window)
    #: real time: a read axis's newest TPDO on the bus to the RPDOs sent in answer
    response: _Window = field(default_factory=_Window)
    #: real time with the host's SYNC, the response's two parts: the drives' answer (the SYNC
    #: sent to their last awaited TPDO) and the host's own time (that TPDO to the RPDOs sent)
    drive_answer: _Window = field(default_factory=_Window)
    host_time: _Window = field(default_factory=_Window)  #: (the second part: see ``drive_answer``)

    def stats(self) -> dict[str, float]:
        """Each window's median, 99th percentile and maximum of the absolute values [us].

        Returns
        -------
        dict[str, float]
            ``{name}_median_us``, ``{name}_p99_us``, ``{name}_max_us`` of each window with a finite value.
        """
        out: dict[str, float] = {}
        for name in ("read", "update", "write", "period_error", "response", "drive_answer", "host_time"):
            a = np.abs(np.array(getattr(self, name))) * 1e6
            a = a[np.isfinite(a)]
            if a.size:
                out[f"{name}_median_us"] = float(np.median(a))
                out[f"{name}_p99_us"] = float(np.percentile(a, 99))
                out[f"{name}_max_us"] = float(a.max())
        return out


class CycleTimes:
    """A cycle's stage times into ``times``, as the host loop measured them.

    In real time also its response: with ``split`` (the host's SYNC) in the drives' answer and the
    host's own time (``Pacing.split``), or over a bus's SYNC (``wall``) from a read axis's newest
    TPDO to the RPDOs sent.

    Parameters
    ----------
    times : StageTimes
        Where they go.
    pacing : Any
        The run's pacing (``Pacing``).
    split : bool
        Real time with the host's SYNC: the response in its two parts.
    realtime : bool
        A real-time run.
    wall : bool
        The read axes' stamps are bus receive times on the wall clock.
    """

    def __init__(self, times: StageTimes, pacing: Any, *, split: bool, realtime: bool, wall: bool) -> None:
        self.times, self.pacing = times, pacing
        self.split, self.realtime, self.wall = split, realtime, wall

    def cycle(
        self, at: tuple[float, float, float, float], send: bool, reads: Sequence[Any]
    ) -> tuple[float, ...]:
        """Record a cycle.

        Parameters
        ----------
        at : tuple[float, float, float, float]
            ``time.perf_counter`` [s] at the tick's start, feedback read, commands checked, written.
        send : bool
            Its commands were the law's new ones.
        reads : Sequence[Any]
            Its samples.

        Returns
        -------
        tuple[float, ...]
            The row's timing [s]: read, update, write (and answer, host with ``split``).
        """
        times, (t0, t1, t2, t3) = self.times, at
        timing: tuple[float, ...] = (t1 - t0, t2 - t1, t3 - t2)
        if self.split:
            answer, host = self.pacing.split(t3) if send else (math.nan, math.nan)
            timing += (answer, host)
            if send:
                times.drive_answer.append(answer)
                times.host_time.append(host)
        if self.realtime and send:
            if self.pacing.sends_sync:  # the host's SYNC to its RPDOs
                times.response.append(t3 - t0)
            elif self.wall:  # the bus's SYNC: a read axis's TPDO on the bus to the RPDOs
                newest = max((fb.stamp for fb in reads if fb.stamp is not None), default=None)
                if newest is not None:
                    times.response.append(time.time() - newest)
        times.read.append(t1 - t0)
        times.update.append(t2 - t1)
        times.write.append(t3 - t2)
        return timing


def run_metrics(
    axes: Sequence[AxisDriver], law: Law, wiring: Wiring, command_limit: float, cycles: int
) -> RunMetrics:
    """The run's `RunMetrics`.

    The chattering of the law's first command against the resolution of its first read axis
    (``rig.host.chatter``), over the run's second half (its steady state, docs/chattering.md).

    Parameters
    ----------
    axes : Sequence[AxisDriver]
        The loop's axes.
    law : Law
        The run's law.
    wiring : Wiring
        Which axes it reads and commands.
    command_limit : float
        The first commanded axis's limit [command unit].
    cycles : int
        The run's cycles.

    Returns
    -------
    RunMetrics
        Empty, to ``add`` to.
    """
    read = wiring.reads[0] if wiring.reads else None
    inner = getattr(law, "inner", law)  # (a FaultyLaw's own law)
    internals = inner.internals
    chatter = RunChatter(
        inner.sensitivity(),
        axes[read].quanta() if read is not None else (0.0, 0.0),
        read=read,
        measures=axes[read].measures if read is not None else (),
        sign_column=internals.index(SIGN_LAW) if SIGN_LAW in internals else None,
        steady_from=cycles // 2,
        command_range=2.0 * command_limit,
    )
    return RunMetrics([a.name for a in axes], [a.measures for a in axes], wiring.commanded, chatter)


class RunMetrics:
    """The run's tracking error, chattering and per-axis peaks, kept cycle by cycle.

    Nothing grows with the run's length: ``add`` each cycle, read at the summary.

    Parameters
    ----------
    names : Sequence[str]
        The axes' names.
    measures : Sequence[Collection[str]]
        The quantities each measures.
    commanded : Sequence[int]
        The axes (indices) of a cycle's commands, in order.
    chatter : RunChatter
        The chattering of the first command.
    """

    def __init__(
        self,
        names: Sequence[str],
        measures: Sequence[Collection[str]],
        commanded: Sequence[int],
        chatter: RunChatter,
    ) -> None:
        self.sq_error = 0.0
        self.max_error = 0.0
        self.chatter = chatter
        self.peaks = {name: dict.fromkeys(("velocity", "current", "command"), 0.0) for name in names}
        #: per axis, its peaks and the measured quantities whose peak is kept
        self._fields = [
            (self.peaks[name], [f for f in ("velocity", "current") if f in m])
            for name, m in zip(names, measures)
        ]
        self._command_peaks = [self.peaks[names[i]] for i in commanded]

    def add(
        self,
        ref: float,
        y: float,
        values: Sequence[Any],
        samples: Sequence[Any],
        internals: Sequence[float] = (),
    ) -> None:
        """One cycle.

        Parameters
        ----------
        ref, y : float
            The reference and the measurement [the law's error unit].
        values : Sequence[Any]
            Its commands.
        samples : Sequence[Any]
            The axes' feedback.
        internals : Sequence[float]
            The law's internals.
        """
        e = ref - y
        self.sq_error += e * e
        e = abs(e)
        if e > self.max_error:  # noqa: PLR1730 - max() without its call, per cycle (NaN alike)
            self.max_error = e
        if values:
            self.chatter.add(
                abs(values[0]) if isinstance(values[0], complex) else values[0], samples, internals
            )
        for (peaks, names), fb in zip(self._fields, samples):
            for name in names:
                value = abs(getattr(fb, name))
                if value > peaks[name]:  # noqa: PLR1730 (as above)
                    peaks[name] = value
        for peaks, command in zip(self._command_peaks, values):
            value = abs(command)
            if value > peaks["command"]:  # noqa: PLR1730 (as above)
                peaks["command"] = value

    def rms_error(self, n: int) -> float:
        """The RMS tracking error over ``n`` cycles.

        Parameters
        ----------
        n : int
            The cycles run.

        Returns
        -------
        float
            [the law's error unit]; NaN for none.
        """
        return math.sqrt(self.sq_error / n) if n else math.nan

    def axis_peaks(self) -> dict[str, dict[str, float]]:
        """Per axis, its peaks.

        Returns
        -------
        dict[str, dict[str, float]]
            name -> ``max_abs_velocity`` [rad/s], ``max_abs_current`` [A], ``max_abs_command``.
        """
        return {name: {f"max_abs_{k}": v for k, v in p.items()} for name, p in self.peaks.items()}
