"""One cycle of the host loop (``rig.host.loop.HostLoop``), once its tick has returned: read every
axis (feedback in SI, its own supervision, its guard), step the law on the axes it reads (on new
samples only: ``rig.host.missed_sample``), check every command (the law's and the profile axes')
against its axis's limits, only then write them all, send the host's heartbeat, and record the row
with the cycle's stage times (``rig.host.loop_stats``). ros2_control's read, update, write.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence
from typing import Any

from drivers.base import AxisDriver, Feedback, feedback_fields
from rig.host.columns import FIELDS
from rig.host.control import Wiring
from rig.host.loop_options import LoopOptions
from rig.host.loop_stats import CycleTimes, RunMetrics
from rig.host.missed_sample import FreshSteps
from rig.host.pacing import Pacing
from rig.host.recorder import Recorder
from rig.host.safety import AxisGuard
from rig.host.start_checks import ReferenceSpan, check_first_samples
from rig.laws.base import Law

__all__ = ["CycleStep"]


class CycleStep:
    """The per-cycle step of a host loop: `cycle` reads, updates, writes and records.

    Parameters
    ----------
    axes, guards : Sequence[AxisDriver], Sequence[AxisGuard]
        The loop's axes and their guards (`rig.host.loop.HostLoop`).
    law, wiring : Law, Wiring
        The law the step updates, and the axes it reads and commands.
    recorder : Recorder
        Each cycle's row goes to it.
    pacing : Pacing
        The run's (its clock stamps the supervision).
    timing : CycleTimes
        Where each cycle's stage times go.
    metrics : RunMetrics
        The run's tracking figures, added to each cycle.
    options : LoopOptions
        The loop's (its heartbeat, missed-sample rule and stop-signal section).
    """

    def __init__(
        self,
        axes: Sequence[AxisDriver],
        guards: Sequence[AxisGuard],
        law: Law,
        wiring: Wiring,
        recorder: Recorder,
        *,
        pacing: Pacing,
        timing: CycleTimes,
        metrics: RunMetrics,
        options: LoopOptions,
    ) -> None:
        self.axes, self.guards, self.law, self.wiring = list(axes), list(guards), law, wiring
        self.recorder, self.pacing, self.timing, self.metrics = recorder, pacing, timing, metrics
        self.heartbeat: Callable[[int], None] | None = options.heartbeat
        self.uncut = options.held if options.held is not None else contextlib.nullcontext()
        self.steps = FreshSteps(
            law, self.axes, wiring.commands, options.missed_sample
        )  #: on new samples only
        #: per axis, its recorded feedback fields as a tuple (one attrgetter call per axis and cycle)
        self.recorded = [
            (i, feedback_fields([f for f in FIELDS if f in a.measures])) for i, a in enumerate(self.axes)
        ]
        self.span: ReferenceSpan | None = None  #: of a position reference, checked at cycle 0
        self.begun = False  #: cycle 0 has been checked (``check_first_samples``)
        self.done = 0  #: cycles recorded
        self.t_end = 0.0  #: perf_counter [s] at the last cycle's commands written

    def read(self, k: int) -> list[Feedback]:
        """Every axis's feedback of cycle ``k``, supervised and guarded.

        Parameters
        ----------
        k : int
            The cycle.

        Returns
        -------
        list[Feedback]
            The samples, in the axes' order.
        """
        now = self.pacing.now()
        samples = []
        for axis, guard in zip(self.axes, self.guards):
            fb = axis.feedback()
            axis.supervise(now)
            guard.check_feedback(fb, k)
            samples.append(fb)
        return samples

    def cycle(self, k: int, t: float, t0: float, late: bool) -> None:
        """Cycle ``k``: read, step the law, check and write the commands, record the row.

        Parameters
        ----------
        k : int
            The cycle.
        t : float
            [s] of the run at it.
        t0 : float
            ``time.perf_counter`` [s] at its tick's start (the tick has returned).
        late : bool
            Its answers missed the pacing's budget (the row's ``late`` column).
        """
        samples = self.read(k)
        if not self.begun:  # cycle 0 (``check_first_samples``)
            check_first_samples(
                self.law, self.axes, self.guards, self.wiring.reads, span=self.span, samples=samples
            )
            self.begun = True
        t1 = time.perf_counter()
        wiring = self.wiring
        reads = [samples[i] for i in wiring.reads]
        out, send = self.steps.step(t, reads)
        values = [*out.commands, *(profile(t) for _, profile in wiring.profiles)]
        # held too: the last commands go again, so the drives' deadlines on them (the toolkit's
        # RPDO deadline) watch the host's cycle, not its samples
        targets = wiring.commanded
        guards, axes = self.guards, self.axes
        for i, value in zip(targets, values):
            guards[i].check_command(value, k)
        t2 = time.perf_counter()
        for i, value in zip(targets, values):
            axes[i].command(value)
        t3 = time.perf_counter()
        if self.heartbeat is not None:  # after the commands: not between a SYNC and its RPDOs
            self.heartbeat(k)
        timing = self.timing.cycle((t0, t1, t2, t3), send, reads)
        scalars = [abs(v) if isinstance(v, complex) else v for v in values]  # a dq command as its magnitude
        self.metrics.add(out.reference, out.measurement, values, samples, out.internals)
        self.t_end = t3
        row: list[Any] = [t, out.reference, out.measurement, scalars[0] if scalars else 0.0, *out.internals]
        for i, fields in self.recorded:
            row += fields(samples[i])
        row += scalars
        row.append(1.0 if late else 0.0)
        with self.uncut:  # a stop signal waits: the row on disk and the count agree
            self.recorder.sample(row, timing)
            self.done += 1
