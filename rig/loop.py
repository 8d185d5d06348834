"""The SYNC-driven host loop of ARCHITECTURE.md, with one safe-stop path.

Each cycle: produce SYNC (lock-step: the emulator steps and its TPDOs arrive
before ``sync()`` returns; on a real bus: canopen's SYNC producer), read the
feedback in SI, run the control law, check the limits, send the command in
RPDO1, record the sample. Two time modes, same code path: lock-step (as fast
as possible, deterministic) and real time (absolute deadlines on the
monotonic clock, a short spin before each deadline, garbage collection frozen
after setup, missed cycles skipped and counted as overruns).

Every way out - a limit, the TPDO watchdog, a lost heartbeat, an EMCY, a NaN
or exception from the controller, Ctrl-C - goes through ``safe_stop``: zero
command, quick stop, disable, flush the recorder, report. The recorder keeps
every sample up to the stop.
"""

from __future__ import annotations

import collections
import gc
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivers.errors import DeviceFault, RigError, SafetyStop
from rig.recorder import Recorder
from rig.safety import Limits

__all__ = ["Feedback", "HostLoop", "Law", "StageTimes"]

log = logging.getLogger(__name__)

#: (position [rad], velocity [rad/s], torque [N m], current [A], statusword)
Feedback = tuple[float, float, float, float, int]
#: law(t, feedback) -> (command, reference, measurement, internals)
Law = Callable[[float, Feedback], tuple[float, float, float, Sequence[float]]]


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

    def stats(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for name in ("read", "update", "write", "period_error"):
            a = np.abs(np.array(getattr(self, name))) * 1e6
            if a.size:
                out[f"{name}_median_us"] = float(np.median(a))
                out[f"{name}_p99_us"] = float(np.percentile(a, 99))
                out[f"{name}_max_us"] = float(a.max())
        return out


class _ChatterCounter:
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


class HostLoop:
    """Run ``law`` against ``drive`` for ``cycles`` periods of ``period`` [s]."""

    def __init__(
        self,
        drive: Any,
        law: Law,
        limits: Limits,
        recorder: Recorder,
        sync: Callable[[], None],
        *,
        period: float,
        cycles: int,
        internals: Sequence[str] = (),
        realtime: bool = False,
        tpdo_stamp: Callable[[], float | None] = lambda: None,
        bus_time: Callable[[], float] = time.time,
        paced_by_bus: bool = False,
    ) -> None:
        self.drive = drive
        self.law = law
        self.limits = limits
        self.recorder = recorder
        self.sync = sync
        self.period = period
        self.cycles = cycles
        self.internals = list(internals)
        self.realtime = realtime
        self.tpdo_stamp = tpdo_stamp
        self.bus_time = bus_time  #: the clock of frame timestamps (the hub's in lock-step)
        self.paced_by_bus = paced_by_bus  #: SYNC comes from the kernel; ``sync()`` waits for the TPDO
        self.times = StageTimes()
        self.overruns = 0
        self.safe_stop_reason: str | None = None
        self.done = 0
        self.elapsed = 0.0  #: wall time of the cycles [s], without setup and the recorder's close
        # streaming metrics: nothing grows with the run's length
        self._sq_error = 0.0
        self._max_error = 0.0
        self._chatter = _ChatterCounter(tol=1e-9)

    @staticmethod
    def columns(internals: Sequence[str]) -> list[str]:
        return ["t", "reference", "measurement", "command", *internals, "read_us", "update_us", "write_us"]

    def _wait(self, deadline: float) -> None:
        """Sleep until shortly before ``deadline`` (monotonic s), then spin.

        The spin yields the GIL (``sleep(0)``) so the bus's receive thread can deliver
        the TPDOs meanwhile; a bare busy loop would hold it for the 5 ms switch interval.
        """
        while True:
            left = deadline - time.perf_counter()
            if left <= 0.0:
                return
            time.sleep(left - 0.0004 if left > 0.0005 else 0.0)

    def run(self) -> dict[str, Any]:
        """Run the cycles; returns the summary (also written by the recorder)."""
        frozen = False
        if self.realtime:
            gc.collect()
            gc.freeze()
            gc.disable()
            frozen = True
        self.recorder.mark_start()
        start = self._t_end = time.perf_counter()
        deadline = last = start
        k = 0
        try:
            while k < self.cycles:
                if self.realtime and not self.paced_by_bus:
                    self._wait(deadline)
                    now = time.perf_counter()
                    self.times.period_error.append(now - deadline)
                    late = int((now - deadline) / self.period)
                    if late >= 1:  # skip the missed cycles
                        self.overruns += late
                        k += late
                        deadline += late * self.period
                        if k >= self.cycles:
                            break
                self._cycle(k)
                if self.paced_by_bus:  # the kernel's SYNC sets the pace: measure it at the TPDO
                    if k:
                        self.times.period_error.append(self._t_end - last - self.period)
                    last = self._t_end
                k += 1
                deadline += self.period
            self.elapsed = self._t_end - start
        except KeyboardInterrupt:
            self.safe_stop("Ctrl-C")
        except SafetyStop as exc:
            self.safe_stop(str(exc))
        except DeviceFault as exc:
            self.safe_stop(f"device fault: {exc}")
        except RigError as exc:
            self.safe_stop(f"{type(exc).__name__}: {exc}")
        except Exception as exc:
            log.exception("exception in the control loop")
            self.safe_stop(f"exception in the control loop: {type(exc).__name__}: {exc}")
        else:
            self._stop_drive(quick=False)  # a run ends with the drive disabled, too
            self._finish()
        finally:
            if frozen:
                gc.enable()
                gc.unfreeze()
        return self.summary()

    def _cycle(self, k: int) -> None:
        t = k * self.period
        t0 = time.perf_counter()
        self.sync()
        drive = self.drive
        try:
            fb = drive.feedback()
            self.limits.watchdog(self.tpdo_stamp())
            if drive.fault is not None:
                raise drive.fault
            state = drive.nmt_state
            if state != "OPERATIONAL":
                raise SafetyStop(f"NMT state {state} (the node reset or was stopped)")
            self.limits.heartbeat(drive.last_heartbeat, self.bus_time())
            self.limits.check_feedback(fb[0], fb[1], fb[3])
        except SafetyStop as exc:
            raise SafetyStop(f"node {drive.node_id}: {exc}") from exc
        t1 = time.perf_counter()
        u, ref, y, extra = self.law(t, fb)
        self.limits.check_command(u)
        t2 = time.perf_counter()
        self.drive.command(u)
        t3 = time.perf_counter()
        self.times.read.append(t1 - t0)
        self.times.update.append(t2 - t1)
        self.times.write.append(t3 - t2)
        self._t_end = t3
        e = ref - y
        self._sq_error += e * e
        self._max_error = max(self._max_error, abs(e))
        self._chatter.add(u)
        self.recorder.sample([t, ref, y, u, *extra, (t1 - t0) * 1e6, (t2 - t1) * 1e6, (t3 - t2) * 1e6])
        self.done = k + 1

    def safe_stop(self, reason: str) -> None:
        """The one way out: zero command, quick stop, disable, flush, report."""
        self.safe_stop_reason = reason
        log.warning("safe stop: %s", reason)
        self._stop_drive(quick=True)
        self._finish()

    def _stop_drive(self, *, quick: bool, tries: int = 5) -> None:
        """Zero command, quick stop (when stopping on a fault), disable; each step retried, since
        the frame that carries it may be lost; a step that still fails is logged and the next runs."""
        steps: list[Callable[[], object]] = [lambda: self.drive.command(0.0)]
        if quick:
            steps.append(self.drive.quick_stop)
        steps.append(self.drive.disable)
        for step in steps:
            for attempt in range(tries):
                try:
                    step()
                    break
                except Exception as exc:
                    if attempt == tries - 1:
                        log.error("stopping the drive: a step failed %d times: %s", tries, exc)

    def _finish(self) -> None:
        self.recorder.close(self.summary())

    def summary(self) -> dict[str, Any]:
        n = self.done
        return {
            "cycles": n,
            "rms_error": math.sqrt(self._sq_error / n) if n else math.nan,
            "max_error": self._max_error if n else math.nan,
            "chattering_count": self._chatter.count,
            "overruns": self.overruns,
            "elapsed_s": self.elapsed,
            "safe_stop_reason": self.safe_stop_reason,
            "run_dir": str(self.recorder.dir),
            "timing": self.times.stats(),
        }
