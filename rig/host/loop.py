"""The SYNC-driven host loop of docs/architecture.md: every axis of the rig, one law, one safe-stop path.

Each cycle: ``pacing.tick()`` (the SYNC and, where the host sends it, the wait for the
TPDOs answering it: the law acts on the sample of the same SYNC in both time modes;
answers later than the budget make a late cycle, counted in its row and the summary,
and ``late_stop`` late cycles in a row are a safe stop), then for every axis its feedback in
SI, its own supervision (EMCY, NMT, heartbeat, statusword, ...) and its guard
(watchdog, NaN, limits); then the law runs once on the axes it reads; every
command (the law's, and the time profiles of profile axes) is checked against
its axis's limits and only then all are written; the sample is recorded. Two
time modes, same code path: lock-step (as fast as possible, deterministic) and
real time (absolute deadlines on the monotonic clock, slept to; with ``spin`` [s], where
the loop thread has no real-time priority, yielding spins over the last part; garbage
collection frozen and young generations collected in a cycle's slack; missed cycles
skipped and counted: ``rig.host.cycle_clock``). The summary is ``rig.host.loop_summary``'s.

Every way out (a limit, the watchdog, a lost heartbeat, an EMCY, a NaN or an
exception from the law, Ctrl-C) goes through ``safe_stop``, and the end of a
run through the same stop: a neutral command (none in CSP), quick stop, the drives' own ramps to
rest (SYNC goes on meanwhile), disable, on every axis (``rig.host.stopping``).
The loop does not close the recorder: the session does, after it has stopped
the frames that feed the trace.
"""

from __future__ import annotations

import contextlib
import gc
import logging
import math
import time
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import Any

import can

from drivers.base import AxisDriver, Feedback, feedback_fields
from drivers.canopen_axis import CanopenAxis
from drivers.errors import CommunicationError, DeviceFault, RigError, SafetyStop, brief
from drivers.master_watch import OtherMaster
from drivers.producer_watch import OtherProducer, ProducerWatch
from rig.host.cycle_clock import collect_in_slack, prime, sleep_until
from rig.host.loop_stats import StageTimes, run_metrics
from rig.host.loop_summary import loop_summary
from rig.host.pacing import Pacing
from rig.host.realtime import YOUNG, cpu_stolen
from rig.host.recorder import Recorder
from rig.host.safety import AxisGuard
from rig.host.signals import stop_reason
from rig.host.start_checks import ReferenceSpan, check_absolute_start, check_reference_window, reference_span
from rig.host.stopping import bring_to_rest
from rig.laws.base import Law, LawStep

__all__ = ["HostLoop", "StageTimes", "Wiring", "missed_periods"]

log = logging.getLogger(__name__)

#: Feedback fields recorded per axis, in this order
FIELDS = ("position", "velocity", "torque", "current")


@dataclass(frozen=True)
class Wiring:
    """Which axes (indices into the loop's axes) the law reads and commands, and the profile axes."""

    reads: tuple[int, ...]
    commands: tuple[int, ...]
    profiles: tuple[tuple[int, Callable[[float], float]], ...] = ()
    #: the law's axes, then the profile axes: the order of a cycle's commands
    commanded: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "commanded", self.commands + tuple(i for i, _ in self.profiles))


def missed_periods(gap: float, period: float) -> int:
    """SYNC periods [s] skipped between two ticks ``gap`` [s] apart when the bus sets the pace
    (kernel SYNC): the loop skips them and counts them as overruns, so its cycle index, and with it
    the watchdog, keeps to the bus's time."""
    return max(0, round(gap / period) - 1)


class HostLoop:
    """Run ``law`` on ``axes`` (wired by ``wiring``) for ``cycles`` periods of ``period`` [s]."""

    def __init__(
        self,
        axes: Sequence[AxisDriver],
        guards: Sequence[AxisGuard],
        law: Law,
        wiring: Wiring,
        *,
        recorder: Recorder,
        pacing: Pacing,
        period: float,
        cycles: int,
        realtime: bool = False,
        stop_timeout: float = 3.0,
        heartbeat: Callable[[int], None] | None = None,
        on_stop: Callable[[], None] | None = None,
        missed_sample: str = "hold",
        held: AbstractContextManager[None] | None = None,
        late_stop: int = 0,
        spin: float = 0.0004,
        producers: ProducerWatch | None = None,
    ) -> None:
        self.axes = list(axes)
        self.guards = list(guards)
        self.law = law
        self.wiring = wiring
        self.recorder = recorder
        self.pacing = pacing
        self.period = period
        self.cycles = cycles
        self.realtime = realtime
        #: real time on the host's SYNC: each cycle's response is split in the drives' answer and
        #: the host's own time (``HostSync.split``; the columns ``answer_us``, ``host_us``)
        self.split = realtime and pacing.sends_sync
        self.times = StageTimes()
        self.overruns = 0
        self.safe_stop_reason: str | None = None
        self.stop_timeout = stop_timeout  #: [s] for the drives' ramps at the end
        self.heartbeat = heartbeat  #: the host's heartbeat, ``heartbeat(k)`` every cycle (or None)
        self.on_stop = on_stop  #: called as the stop begins (later stop signals do not cut it)
        #: the section a stop signal waits for (``StopRequests.held``): a cycle's row and count
        self.uncut = held if held is not None else contextlib.nullcontext()
        self.missed_sample = missed_sample  #: "hold" | "zero" (``_step``)
        self.held = 0  #: cycles in which a read axis had no new sample
        self.late = 0  #: cycles whose answers missed the pacing's budget (``Pacing.late``)
        self.late_stop = late_stop  #: that many late cycles in a row: a safe stop (0: never)
        self.producers = producers  #: another producer's watch (``safe_stop``)
        self._late_run = 0
        #: [s] before a deadline the loop stops sleeping and spins yielding (0: sleeps to it;
        #: never at real-time priority, where a spin starves the threads that carry the frames)
        self.spin = spin
        self.gc_young = YOUNG  #: young objects before a collection in the slack (``_collect``)
        self.collections = 0  #: collections run in the slack
        self.granted: dict[str, Any] | None = None  #: real time: what the system granted (the summary's)
        self._last_out: LawStep | None = None
        self._stamps: list[float | None] = []
        #: the read axes' sample stamps are bus receive times on the wall clock (real time, CANopen)
        self._wall_stamps = realtime and all(isinstance(axes[i], CanopenAxis) for i in wiring.reads)
        self.stop_confirmed: bool | None = None  #: every axis came to rest by its own stop
        self.still_turning: dict[str, float | None] = {}  #: axes not at rest after it [rad/s]
        self.done = 0
        self._begun = False
        self._span: ReferenceSpan | None = None  #: of a position reference (``run``)
        self.elapsed = 0.0  #: wall time of the cycles [s], without setup and the recorder's close
        self._t_start = self._t_end = 0.0  #: perf_counter [s] of the first cycle, the last one's end
        #: [s] of CPU time the hypervisor took during the cycles (``cpu_stolen``), and its count then
        self.stolen: float | None = None
        self._stolen_at: float | None = None
        limit = guards[wiring.commands[0]].limits.command if wiring.commands else math.inf
        self.metrics = run_metrics(self.axes, law, wiring, limit, cycles)
        #: per axis, its recorded feedback fields as a tuple (one attrgetter call per axis and cycle)
        self._recorded = [
            (i, feedback_fields([f for f in FIELDS if f in a.measures])) for i, a in enumerate(self.axes)
        ]

    @staticmethod
    def columns(axes: Sequence[AxisDriver], law: Law, wiring: Wiring, *, split: bool = False) -> list[str]:
        """The recorder's columns: law level, the law's internals, per axis, timing [us] (with
        ``split``, a real-time run on the host's SYNC: the response's two parts too)."""
        per_axis = [f"{a.name}.{f}" for a in axes for f in FIELDS if f in a.measures]
        commands = [f"{axes[i].name}.command" for i in wiring.commanded]
        return [
            "t",
            "reference",
            "measurement",
            "command",
            *law.internals,
            *per_axis,
            *commands,
            "late",
            "read_us",
            "update_us",
            "write_us",
            *(("answer_us", "host_us") if split else ()),
        ]

    def run(self, progress: Callable[[int], None] | None = None) -> dict[str, Any]:
        """Run the cycles (``progress(k)`` every 1 % of them); returns the summary."""
        frozen = False
        if self.realtime:
            gc.collect()
            gc.freeze()
            gc.disable()
            frozen = True
        try:
            self._span = reference_span(self.law, self.guards, self.wiring.reads, self.cycles, self.period)
            self.recorder.mark_start()
            with self.pacing.owning():  # given back before any stop: its SDO needs the receive thread
                self._prime()
                self._cycles(progress)
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM/SIGHUP (``rig.host.signals``)
            self.safe_stop(stop_reason(exc))
        except SafetyStop as exc:
            self.safe_stop(str(exc), suspect=not isinstance(exc, (OtherMaster, OtherProducer)))
        except DeviceFault as exc:
            self.safe_stop(f"device fault: {exc}")
        except RigError as exc:
            if isinstance(exc.__cause__, (OSError, can.CanError)):  # a driver's send on a lost bus
                self.safe_stop(f"the bus is lost: {exc}")
            else:
                self.safe_stop(f"{type(exc).__name__}: {exc}")
        except (OSError, can.CanError) as exc:  # a send on a bus that went away
            self.safe_stop(f"the bus is lost: {type(exc).__name__}: {brief(exc)}")
        except Exception as exc:
            log.exception("exception in the control loop")
            self.safe_stop(f"exception in the control loop: {type(exc).__name__}: {exc}")
        else:
            self._stop_axes()  # a run ends with every axis at rest and disabled, too
        finally:
            if frozen:
                gc.enable()
                gc.unfreeze()
        return self.summary()

    def _prime(self) -> None:
        """Real time with the host's SYNC: ``rig.host.cycle_clock.prime`` before cycle 0 (the other
        pacings bring the first samples with cycle 0's own tick: ``_begin`` checks)."""
        if self.realtime and not self.pacing.paced_by_bus:
            prime(self.pacing, self.axes, self.guards, self.period, self.heartbeat)

    def _begin(self, samples: list[Feedback]) -> None:
        """Cycle 0: every axis has sent a sample (else CommunicationError naming the silent ones,
        before any command); the law gets the first samples (``Law.begin``: a position
        reference's origin)."""
        silent = [axis.where for axis in self.axes if not axis.has_sample()]
        if silent:
            raise CommunicationError(f"no process data from {', '.join(silent)} after the first SYNC")
        self.law.begin([samples[i] for i in self.wiring.reads])
        law = getattr(self.law, "inner", self.law)  # (a FaultyLaw's own law)
        if law.position_reference and self.wiring.reads:
            i = self.wiring.reads[0]
            check_absolute_start(law, self.guards[i], samples[i])
            if self._span is not None:
                check_reference_window(self._span, law.offset, self.guards[i], samples[i])
        self._begun = True

    def _cycles(self, progress: Callable[[int], None] | None) -> None:
        self._stolen_at = cpu_stolen() if self.realtime else None
        start = self._t_start = self._t_end = time.perf_counter()
        deadline = start
        every = max(1, self.cycles // 100)
        k = 0
        pace = self.realtime and not self.pacing.paced_by_bus
        by_bus = self.pacing.paced_by_bus
        last_tick: float | None = None
        while k < self.cycles:
            if pace:
                sleep_until(deadline, self.spin)
                now = time.perf_counter()
                self.times.period_error.append(now - deadline)
                late = int((now - deadline) / self.period)
                if late >= 1:  # skip the missed cycles
                    self.overruns += late
                    k += late
                    deadline += late * self.period
                    if k >= self.cycles:
                        break
            t0 = time.perf_counter()
            self.pacing.tick()
            if by_bus:
                now = time.perf_counter()
                if last_tick is not None:
                    missed = missed_periods(now - last_tick, self.period)
                    self.overruns += missed
                    self.times.period_error.append(now - last_tick - (missed + 1) * self.period)
                    k += missed
                last_tick = now
                if k >= self.cycles:
                    break
            late = self.pacing.late
            self._cycle(k, t0, late=late)
            if late:
                self._late(k)
            else:
                self._late_run = 0
            k += 1
            deadline += self.period
            if self.realtime:
                self._collect(deadline if pace else t0 + self.period)
            if progress is not None and k % every == 0:
                progress(k)

    def _collect(self, deadline: float) -> None:
        """Real time, the collector disabled (``run``): young garbage in the slack (``collect_in_slack``)."""
        if collect_in_slack(deadline, self.period, self.gc_young):
            self.collections += 1

    def _read(self, k: int) -> list[Feedback]:
        now = self.pacing.now()
        samples = []
        for axis, guard in zip(self.axes, self.guards):
            fb = axis.feedback()
            axis.supervise(now)
            guard.check_feedback(fb, k)
            samples.append(fb)
        return samples

    def _late(self, k: int) -> None:
        """Cycle ``k`` was late: counted; ``late_stop`` of them in a row are a safe stop."""
        self.late += 1
        self._late_run += 1
        if self.late_stop and self._late_run >= self.late_stop:
            budget = getattr(self.pacing, "budget", math.nan)
            raise SafetyStop(
                f"{self._late_run} late cycles in a row (cycles {k - self._late_run + 1}-{k}): the TPDOs "
                f"answering SYNC missed the budget of {budget * 1e6:.0f} us ([run] answer_budget; "
                f"[run] late_stop = {self.late_stop})"
            )

    def _cycle(self, k: int, t0: float, *, late: bool = False) -> None:
        """Cycle ``k``, whose tick started at ``t0`` (perf_counter s) and has returned (``late``:
        its answers missed their budget)."""
        t = k * self.period
        samples = self._read(k)
        if not self._begun:
            self._begin(samples)
        t1 = time.perf_counter()
        wiring = self.wiring
        reads = [samples[i] for i in wiring.reads]
        out, send = self._step(t, reads)
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
        timing: tuple[float, ...] = (t1 - t0, t2 - t1, t3 - t2)
        if self.split:
            answer, host = self.pacing.split(t3) if send else (math.nan, math.nan)
            timing += (answer, host)
            if send:
                self.times.drive_answer.append(answer)
                self.times.host_time.append(host)
        if self.realtime and send:
            if self.pacing.sends_sync:  # the host's SYNC to its RPDOs
                self.times.response.append(t3 - t0)
            elif self._wall_stamps:  # the bus's SYNC: a read axis's TPDO on the bus to the RPDOs
                newest = max((fb.stamp for fb in reads if fb.stamp is not None), default=None)
                if newest is not None:
                    self.times.response.append(time.time() - newest)
        scalars = [abs(v) if isinstance(v, complex) else v for v in values]  # a dq command as its magnitude
        self.metrics.add(out.reference, out.measurement, values, samples, out.internals)
        self.times.read.append(t1 - t0)
        self.times.update.append(t2 - t1)
        self.times.write.append(t3 - t2)
        self._t_end = t3
        row = [t, out.reference, out.measurement, scalars[0] if scalars else 0.0, *out.internals]
        for i, fields in self._recorded:
            row += fields(samples[i])
        row += scalars
        row.append(1.0 if late else 0.0)
        with self.uncut:  # a stop signal waits: the row on disk and the count agree
            self.recorder.sample(row, timing)
            self.done += 1  #: cycles run (skipped ones are under ``overruns``)

    def _step(self, t: float, reads: list[Feedback]) -> tuple[LawStep, bool]:
        """The law's step on new samples, and whether to send its commands. A cycle in which a
        read axis has no new sample (a TPDO missed or late) does not step the law on stale
        feedback: ``missed_sample = "hold"`` keeps the last commands (sent again, the same values:
        the drives hold them, and their deadlines see a host alive), "zero" sends the neutral ones."""
        stamps = [fb.stamp for fb in reads]
        last = self._last_out
        fresh = True
        if last is not None:
            for s, p in zip(stamps, self._stamps):
                if s is None or s == p:
                    fresh = False
                    break
        self._stamps = stamps
        if fresh or last is None:
            self._last_out = self.law.step(t, reads)
            return self._last_out, True
        self.held += 1
        if self.missed_sample == "hold":
            return last, False
        neutral = [self.axes[i].neutral_command() for i in self.wiring.commands]
        commands = tuple(c if n is None else n for c, n in zip(last.commands, neutral))
        return LawStep(commands, last.reference, last.measurement, last.internals), True

    def safe_stop(self, reason: str, *, suspect: bool = False) -> None:
        """The one way out: a neutral command, quick stop, the drives' ramps to rest, disable.
        ``suspect``: a check of a sample stopped it (``ProducerWatch.cause`` may name another producer)."""
        self.safe_stop_reason = reason
        log.warning("safe stop: %s", reason)
        mark = self.producers.syncs if self.producers is not None else 0
        self._stop_axes()
        if self.producers is not None and suspect:
            self.safe_stop_reason = self.producers.cause(reason, mark)

    def _stop_axes(self) -> None:
        """Bring every axis to rest by its own ramp, then disable it (``rig.host.stopping``)."""
        if self.on_stop is not None:
            self.on_stop()
        self.elapsed = self._t_end - self._t_start  # a safe stop's too
        if self._stolen_at is not None and (now := cpu_stolen()) is not None:
            self.stolen = now - self._stolen_at
        stop = bring_to_rest(
            self.axes,
            [self.axes[i] for i in self.wiring.commanded],
            self.pacing,
            period=self.period,
            timeout=self.stop_timeout,
            realtime=self.realtime,
            heartbeat=self.heartbeat,
        )
        self.stop_confirmed, self.still_turning = stop.confirmed, stop.turning

    def summary(self) -> dict[str, Any]:
        """The run's summary as it stands (``rig.host.loop_summary``)."""
        return loop_summary(self)
