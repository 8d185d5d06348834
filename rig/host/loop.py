"""The SYNC-driven host loop of docs/architecture.md: every axis of the rig, one law, one safe-stop path.

Each cycle: ``pacing.tick()`` (the SYNC and, where the host sends it, the wait for the TPDOs
answering it: the law acts on the sample of the same SYNC in both time modes; answers later than
the budget make a late cycle, counted in its row and the summary, and ``late_stop`` late cycles in
a row are a safe stop), then the cycle's step (``rig.host.cycle_step``: read every axis, update the
law, check and write every command, record). Two time modes, same code path: lock-step (as fast as
possible, deterministic) and real time (absolute deadlines on the monotonic clock, slept to; with
``spin`` [s], where the loop thread has no real-time priority, yielding spins over the last part;
garbage collection frozen and young generations collected in a cycle's slack; missed cycles
skipped and counted: ``rig.host.cycle_clock``). The summary is ``rig.host.loop_summary``'s.

Every way out (a limit, the watchdog, a lost heartbeat, an EMCY, a NaN or an exception from the
law, Ctrl-C) goes through ``safe_stop``, and the end of a run through the same stop: a neutral
command (none in CSP), quick stop, the drives' own ramps to rest (SYNC goes on meanwhile),
disable, on every axis (``rig.host.stopping``). The loop does not close the recorder: the session
does, after it has stopped the frames that feed the trace.
"""

from __future__ import annotations

import gc
import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

from drivers.base import AxisDriver
from drivers.errors import SafetyStop
from rig.host.columns import loop_columns
from rig.host.control import Wiring
from rig.host.cycle_clock import collect_in_slack, missed_periods, prime, sleep_until
from rig.host.cycle_step import CycleStep
from rig.host.loop_options import LoopOptions
from rig.host.loop_stats import CycleTimes, StageTimes, run_metrics
from rig.host.loop_summary import loop_summary
from rig.host.pacing import Pacing
from rig.host.realtime import YOUNG, cpu_stolen
from rig.host.recorder import Recorder
from rig.host.safety import AxisGuard
from rig.host.signals import stop_reason
from rig.host.start_checks import reference_span
from rig.host.stop_causes import cause_of
from rig.host.stopping import bring_to_rest
from rig.host.timebase import Timebase
from rig.laws.base import Law

__all__ = ["HostLoop", "LoopOptions", "StageTimes", "Wiring", "missed_periods"]

log = logging.getLogger(__name__)


class HostLoop:
    """Run ``law`` on ``axes`` (wired by ``wiring``) for ``cycles`` periods of ``timebase``.

    Parameters
    ----------
    axes : Sequence[AxisDriver]
        Every axis of the run, set up.
    guards : Sequence[AxisGuard]
        Their guards, in the same order.
    law : Law
        The run's law.
    wiring : Wiring
        Which axes it reads and commands, and the profile axes.
    recorder : Recorder
        Where the rows go (the session closes it).
    pacing : Pacing
        How a cycle starts.
    timebase : Timebase
        The period, and lock-step or real time.
    cycles : int
        The cycles to run.
    options : LoopOptions | None
        The rest (None: a lock-step run's defaults).
    """

    def __init__(
        self,
        axes: Sequence[AxisDriver],
        guards: Sequence[AxisGuard],
        law: Law,
        wiring: Wiring,
        *,
        recorder: Recorder,
        pacing: Pacing,
        timebase: Timebase,
        cycles: int,
        options: LoopOptions | None = None,
    ) -> None:
        o = self.options = options or LoopOptions()
        self.axes, self.guards = list(axes), list(guards)
        self.law, self.wiring, self.recorder, self.pacing = law, wiring, recorder, pacing
        self.timebase, self.cycles = timebase, cycles
        realtime = timebase.realtime
        #: real time on the host's SYNC: each cycle's response is split in the drives' answer and
        #: the host's own time (``HostSync.split``; the columns ``answer_us``, ``host_us``)
        self.split = realtime and pacing.sends_sync
        self.times = StageTimes()
        self.overruns = 0
        self.safe_stop_reason: str | None = None
        self.heartbeat = o.heartbeat
        self.late = 0  #: cycles whose answers missed the pacing's budget (``Pacing.late``)
        self._late_run = 0
        self.spin = o.spin  #: (``LoopOptions.spin``; 0 at real-time priority)
        self.gc_young = YOUNG  #: young objects before a collection in the slack (``_collect``)
        self.collections = 0  #: collections run in the slack
        self.granted: dict[str, Any] | None = None  #: real time: what the system granted (the summary's)
        #: the read axes' sample stamps are bus receive times on the wall clock (real time, CANopen)
        wall = realtime and all(axes[i].wall_stamps for i in wiring.reads)
        timing = CycleTimes(self.times, pacing, split=self.split, realtime=realtime, wall=wall)
        limit = guards[wiring.commands[0]].limits.command if wiring.commands else math.inf
        metrics = self.metrics = run_metrics(self.axes, law, wiring, limit, cycles)
        #: each cycle once its tick has returned (``rig.host.cycle_step``)
        self.step = CycleStep(
            axes, guards, law, wiring, recorder, pacing=pacing, timing=timing, metrics=metrics, options=o
        )
        self.stop_confirmed: bool | None = None  #: every axis came to rest by its own stop
        self.still_turning: dict[str, float | None] = {}  #: axes not at rest after it [rad/s]
        self.elapsed = 0.0  #: wall time of the cycles [s], without setup and the recorder's close
        self._t_start = 0.0  #: perf_counter [s] of the first cycle
        #: [s] of CPU time the hypervisor took during the cycles (``cpu_stolen``), and its count then
        self.stolen: float | None = None
        self._stolen_at: float | None = None

    columns = staticmethod(loop_columns)  #: the recorder's columns (``rig.host.columns``)

    @property
    def held(self) -> int:
        """Cycles in which a read axis had no new sample (``rig.host.missed_sample``)."""
        return self.step.steps.held

    @property
    def done(self) -> int:
        """Cycles run (skipped ones are under ``overruns``)."""
        return self.step.done

    def run(self, progress: Callable[[int], None] | None = None) -> dict[str, Any]:
        """Run the cycles, then bring every axis to rest and disabled, whatever ended them.

        Parameters
        ----------
        progress : Callable[[int], None] | None
            Called with the cycle's index every 1 % of them (None: not).

        Returns
        -------
        dict[str, Any]
            The summary (`summary`).
        """
        frozen, tb = False, self.timebase
        if tb.realtime:
            gc.collect()
            gc.freeze()
            gc.disable()
            frozen = True
        try:
            self.step.span = reference_span(self.law, self.guards, self.wiring.reads, self.cycles, tb.period)
            self.recorder.mark_start()
            with self.pacing.owning():  # given back before any stop: its SDO needs the receive thread
                if tb.realtime and not self.pacing.paced_by_bus:  # the others' tick brings cycle 0's
                    prime(self.pacing, self.axes, self.guards, tb.period, self.heartbeat)
                self._cycles(progress)
                self._last_look()
        except Exception as exc:
            reason, suspect = cause_of(exc)
            self.safe_stop(reason, suspect=suspect)
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM/SIGHUP (``rig.host.signals``)
            self.safe_stop(stop_reason(exc))
        else:
            self._stop_axes()  # a run ends with every axis at rest and disabled, too
        finally:
            if frozen:
                gc.enable()
                gc.unfreeze()
        return self.summary()

    def _cycles(self, progress: Callable[[int], None] | None) -> None:
        period, realtime = self.timebase.period, self.timebase.realtime
        self._stolen_at = cpu_stolen() if realtime else None
        start = self._t_start = self.step.t_end = time.perf_counter()
        deadline = start
        every = max(1, self.cycles // 100)
        k = 0
        pace = realtime and not self.pacing.paced_by_bus
        by_bus = self.pacing.paced_by_bus
        last_tick: float | None = None
        step = self.step.cycle
        while k < self.cycles:
            if pace:
                sleep_until(deadline, self.spin)
                now = time.perf_counter()
                self.times.period_error.append(now - deadline)
                late = int((now - deadline) / period)
                if late >= 1:  # skip the missed cycles
                    self.overruns += late
                    k += late
                    deadline += late * period
                    if k >= self.cycles:
                        break
            t0 = time.perf_counter()
            self.pacing.tick()
            if by_bus:
                now = time.perf_counter()
                if last_tick is not None:
                    missed = missed_periods(now - last_tick, period)
                    self.overruns += missed
                    self.times.period_error.append(now - last_tick - (missed + 1) * period)
                    k += missed
                last_tick = now
                if k >= self.cycles:
                    break
            late = self.pacing.late
            step(k, k * period, t0, late)
            if late:
                self._late(k)
            else:
                self._late_run = 0
            k += 1
            deadline += period
            if realtime:
                self._collect(deadline if pace else t0 + period)
            if progress is not None and k % every == 0:
                progress(k)

    def _last_look(self) -> None:
        """After the last cycle, before the stop: its answers still owed come in (``Pacing.settle``),
        and every axis is supervised once more. A frame the last cycle's supervision could not see
        yet (another master's RPDO, an EMCY, one the late answers were behind) is a safe stop named
        as such, not a clean end."""
        self.pacing.settle()
        now = self.pacing.now()
        for axis in self.axes:
            axis.supervise(now)

    def _collect(self, deadline: float) -> None:
        """Real time, the collector disabled (``run``): young garbage in the slack (``collect_in_slack``)."""
        if collect_in_slack(deadline, self.timebase.period, self.gc_young):
            self.collections += 1

    def _late(self, k: int) -> None:
        """Cycle ``k`` was late: counted; ``late_stop`` of them in a row are a safe stop."""
        self.late += 1
        self._late_run += 1
        if self.options.late_stop and self._late_run >= self.options.late_stop:
            budget = getattr(self.pacing, "budget", math.nan)
            raise SafetyStop(
                f"{self._late_run} late cycles in a row (cycles {k - self._late_run + 1}-{k}): the TPDOs "
                f"answering SYNC missed the budget of {budget * 1e6:.0f} us ([run] answer_budget; "
                f"[run] late_stop = {self.options.late_stop})"
            )

    def safe_stop(self, reason: str, *, suspect: bool = False) -> None:
        """The one way out: a neutral command, quick stop, the drives' ramps to rest, disable.

        Parameters
        ----------
        reason : str
            Why, for the summary.
        suspect : bool
            A check of a sample stopped it (``ProducerWatch.cause`` may name another producer).
        """
        self.safe_stop_reason = reason
        log.warning("safe stop: %s", reason)
        producers = self.options.producers
        mark = producers.syncs if producers is not None else 0
        self._stop_axes()
        if producers is not None and suspect:
            self.safe_stop_reason = producers.cause(reason, mark)

    def _stop_axes(self) -> None:
        """Bring every axis to rest by its own ramp, then disable it (``rig.host.stopping``)."""
        if self.options.on_stop is not None:
            self.options.on_stop()
        self.elapsed = self.step.t_end - self._t_start  # a safe stop's too
        if self._stolen_at is not None and (now := cpu_stolen()) is not None:
            self.stolen = now - self._stolen_at
        stop = bring_to_rest(
            self.axes,
            [self.axes[i] for i in self.wiring.commanded],
            self.pacing,
            period=self.timebase.period,
            timeout=self.options.stop_timeout,
            realtime=self.timebase.realtime,
            heartbeat=self.heartbeat,
        )
        self.stop_confirmed, self.still_turning = stop.confirmed, stop.turning

    def summary(self) -> dict[str, Any]:
        """The run's summary as it stands.

        Returns
        -------
        dict[str, Any]
            ``rig.host.loop_summary.loop_summary``'s.
        """
        return loop_summary(self)
