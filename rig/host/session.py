"""A run of a configured rig: the one public path from a configuration to a running host loop.

``Session(cfg, emulate=..., duration=... or cycles=...)`` builds, in this order, and moves nothing yet:
``cfg`` was checked when it was loaded (``rig.config``), so nothing of it is checked again: first
what needs no bus (the period, the law of ``rig.laws.make_law``, the profiles; what the run's
mode needs of the file, and the output folder as it is now, are refused here, before anything is
opened); then
the transports (the CAN bus, or with ``emulate`` the emulated world of
``rig.host.emulation``), the axis drivers, the recorder (the configuration first, then every
frame). ``start()`` sets every
axis up, enables it, and makes the pacing and the loop. ``run()`` runs the loop and then,
in this order, stops SYNC, stops the frames that feed the trace, and closes the
recorder with the summary. ``close()`` disables and releases every axis and
the transports; a session is a context manager, which, where a stop signal came during it
(``rig.host.signals``), raises it once it has closed: a study of many runs ends with the one
the signal stopped. ``rig run``, ``rig identify``,
the benchmarks and the fault suite all run through here.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import logging
import math
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drivers.base import AxisDriver
from drivers.bus import ReceiveWatch, open_bus, scan_command
from drivers.canopen_axis import CanopenAxis
from drivers.errors import ConfigError, NodeSilent, RigError
from drivers.master_watch import MasterWatch, OtherMaster
from drivers.producer_watch import ProducerWatch
from drivers.profiles import parse_profile
from rig.config import RigConfig
from rig.host.axes import open_axis
from rig.host.bus_load import bus_load, warn_bus_load
from rig.host.columns import describe_columns
from rig.host.heartbeat import HostHeartbeat
from rig.host.injected import with_injected_faults
from rig.host.loop import HostLoop, Wiring
from rig.host.loop_summary import missed_period
from rig.host.pacing import (
    ExternalSync,
    FreeRun,
    HostSync,
    InProcessLockstep,
    KernelSync,
    Pacing,
    WireLockstep,
)
from rig.host.realtime import RealtimeRequest, receive_threads, request
from rig.host.recorder import Recorder, output_folder
from rig.host.references import reference_of
from rig.host.safety import AxisGuard
from rig.host.signals import StopRequests
from rig.host.time_mode import TimeModeProbe
from rig.host.trace import TracedNetwork, attach_received, detach_received
from rig.laws import Law, make_law
from rig.live.channels import channels_of
from rig.live.view import LiveView

if TYPE_CHECKING:  # a run on a real bus loads no plant_emulator module
    from rig.host.emulation import Emulation

__all__ = ["Session", "build_law", "run_config"]

log = logging.getLogger(__name__)

#: [s] the least wait for an emulated drive's state in lock-step (``Session._wait``): a hang guard
HANG_GUARD = 30.0


def run_config(
    cfg: RigConfig,
    *,
    emulate: bool,
    duration: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    live: LiveView | None = None,
    started: Callable[[list[AxisDriver]], None] | None = None,
) -> dict[str, Any]:
    """Build, start and run ``cfg``; returns the summary (``cycles``, ``rms_error``, ..., ``run_dir``).
    ``progress(k, cycles)`` every 1 % of the run; ``live`` shows the rows as they come;
    ``started(axes)`` once every axis is set up and enabled, before the first cycle."""
    with Session(cfg, emulate=emulate, duration=duration) as session:
        session.start()
        if started is not None:
            started(session.axes)
        n = session.cycles
        return session.run(None if progress is None else lambda k: progress(k, n), live=live)


def build_law(cfg: RigConfig, period: float) -> Law:
    """The law of ``[controller]`` at ``period`` [s] (checked with its axes when ``cfg`` was loaded)."""
    c = cfg.controller
    law = make_law(
        c.kind, c.params, period=period, reference=reference_of(cfg.reference), origin=cfg.reference.origin
    )
    return with_injected_faults(law, cfg.faults)


class Session:
    """See the module docstring."""

    def __init__(
        self, cfg: RigConfig, *, emulate: bool, duration: float | None = None, cycles: int | None = None
    ) -> None:
        self.cfg = cfg
        self.emulate = emulate
        self.emulation: Emulation | None = None
        self.axes: list[AxisDriver] = []
        self._bus: Any = None
        self._tap: Callable[[Any], None] | None = None
        self._rx_tap: Callable[[Any], None] | None = None  #: the trace's listener of frames received
        self.pacing: Pacing = Pacing()
        self.master_watch: MasterWatch | None = None  #: another master on a real CAN bus
        self.producer_watch: ProducerWatch | None = None  #: another producer on its TPDOs' COB-IDs
        self.bus_figures: dict[str, Any] = {}  #: real time over a CAN bus: the cycle's share of it
        self.loop: HostLoop | None = None
        self.signals = StopRequests()  #: SIGINT, SIGTERM, SIGHUP: the one safe stop
        self.signals.install()
        self._frozen = False  #: start() froze the heap (real time) and nothing has unfrozen it
        try:
            self._build(duration, cycles)
        except BaseException:
            self.close()
            raise

    # --- building ------------------------------------------------------------------------------
    def _period(self) -> float:
        """The run's period [s] (``RigConfig.period``); what the run's mode needs of the file: a
        real bus a ``[run] period``, ``--emulate`` a preset for the CANopen axes."""
        cfg = self.cfg
        if self.emulate:
            canopen_axes = [a.name for a in cfg.axes if a.kind != "modbus"]
            if canopen_axes and cfg.emulator.physics is None:
                raise ConfigError(
                    f"{cfg.source}: --emulate needs [emulator] preset or device for the CANopen axes "
                    f"{canopen_axes}"
                )
        elif not cfg.run.period > 0.0:
            raise ConfigError(
                f"{cfg.source}: [run] period must be set (> 0 s) for a real bus; without hardware, run it "
                "with --emulate (the emulator in this process) or against `rig emulate` in another"
            )
        return cfg.period

    def _cycles(self, duration: float | None, cycles: int | None) -> int:
        """The run's cycles: ``cycles``, or ``duration`` [s] (default: ``[run] duration``) of periods."""
        if cycles is not None:
            if cycles < 1:
                raise ValueError(f"cycles = {cycles!r}: must be >= 1")
            return cycles
        d = self.cfg.run.duration if duration is None else duration
        if not (math.isfinite(d) and d > 0.0):
            raise ValueError(f"duration = {d!r}: must be a finite time > 0 s")
        return round(d / self.period)

    def _transports(self) -> None:
        cfg = self.cfg
        if self.emulate:
            from rig.host import emulation  # the emulator only where it runs

            self.emulation = emulation.Emulation(cfg)
            self.network: Any = self.emulation.network
            return
        self.network = TracedNetwork()
        if any(a.kind != "modbus" for a in cfg.axes):
            b = cfg.bus
            extra = {"host": b.host, "port": b.port} if b.interface == "socketcand" else {}
            self._bus = open_bus(b.interface, b.channel, bitrate=b.bitrate or None, **extra)
            self.network.bus = self._bus
            self.network.connect()
            self.network.notifier.add_listener(ReceiveWatch())  # a lost bus: a safe stop, not a dead thread
            nodes = [a.node_id for a in cfg.axes if a.kind != "modbus"]  # heard from the bus's opening
            watch = self.master_watch = MasterWatch(self.network, nodes, sync=b.sync != "external")
            self.producer_watch = ProducerWatch(self.network, echoes=lambda: watch.echoes)

    def _build(self, duration: float | None, cycles: int | None) -> None:
        cfg = self.cfg
        # first what needs no bus: a bad value is one error and nothing was opened
        period = self.period = self._period()
        self.answer_budget = cfg.run.answer_budget or period / 2.0
        self.cycles = self._cycles(duration, cycles)
        law = build_law(cfg, period)
        names = [a.name for a in cfg.axes]
        wiring = Wiring(
            tuple(names.index(n) for n in cfg.controller.reads),
            tuple(names.index(n) for n in cfg.controller.commands),
            tuple((names.index(a.name), parse_profile(a.profile)) for a in cfg.axes if a.profile),
        )
        self.law, self.wiring = law, wiring
        output_folder(cfg.run.output, f"{cfg.source}: [run]")
        # then the bus (or the emulated world), the axes on it, the recorder
        self._transports()
        for a in cfg.axes:
            spec = self.emulation.endpoint(a) if self.emulation else a
            spec = dataclasses.replace(spec, mode_timeout=self._wait(spec.mode_timeout))
            realtime = cfg.run.time == "realtime"
            axis = open_axis(spec, network=self.network, period=period, bus=cfg.bus, realtime=realtime)
            self.axes.append(axis)
            if isinstance(axis, CanopenAxis):  # before set-up: a TPDO is counted from its slot's making
                axis.producer_watch = self.producer_watch
        self._made_output = not Path(cfg.run.output).exists()  #: the recorder makes the folder
        # flushed every 50 ms of run time: a killed host loses at most that
        self.recorder = Recorder(cfg.run.output, cfg.run.name, flush_period=0.05, trace=cfg.run.trace)
        self.recorder.write_config(cfg.as_dict() | {"resolved_period": period, "emulate": self.emulate})
        self._attach_trace()

    def _attach_trace(self) -> None:
        tap = self._tap = self.recorder.on_frame
        if self.emulation is not None:
            self.emulation.add_tap(tap)
        else:
            self.network.tx_tap = tap  # the trace: every frame sent,
            self._rx_tap = attach_received(self.network, tap)  # and every frame received

    def _detach_trace(self) -> None:
        tap, self._tap = self._tap, None
        if tap is None:
            return
        if self.emulation is not None:
            self.emulation.remove_tap(tap)
            return
        self.network.tx_tap = None
        rx_tap, self._rx_tap = self._rx_tap, None
        if rx_tap is not None:
            detach_received(self.network, rx_tap)

    def _wait(self, timeout: float) -> float:
        """The wall-clock time [s] to wait for a drive to reach a state (enabled, a mode): the
        configured one, but in lock-step against the in-process emulator at least ``HANG_GUARD``:
        there the emulated drive answers as soon as this process runs, so a timeout can only
        guard against a hang (1 s ran out on a machine loaded a dozen deep: a deterministic
        test failed)."""
        lockstep = self.emulation is not None and self.cfg.run.time == "lockstep"
        return max(timeout, HANG_GUARD) if lockstep else timeout

    def _idle(self) -> Callable[[], None] | None:
        """While set-up waits for a drive (0x6061 after 0x6060): in lock-step, a SYNC (time
        passes only by SYNCs there); in real time, the drivers' own short sleep (None)."""
        if self.emulation is not None:
            return self.emulation.sync
        if self.cfg.run.time == "lockstep" and self._bus is not None:
            return self.network.sync.transmit  # type: ignore[no-any-return]
        return None

    def _time_probe(self) -> TimeModeProbe | None:
        """Over a bus with the host's SYNC: the heartbeats that tell how each node keeps time."""
        axes = [a for a in self.axes if isinstance(a, CanopenAxis)]
        if self.emulation is not None or not axes or self.cfg.bus.sync == "external":
            return None
        return TimeModeProbe(self.network, axes)

    def _pacing(self, period: float) -> Pacing:
        cfg = self.cfg
        if self.emulation is not None:
            return InProcessLockstep(period, self.emulation.sync, self.emulation.steppers)
        canopen_axes = [a for a in self.axes if isinstance(a, CanopenAxis)]
        if not canopen_axes:
            return FreeRun()
        timeout = min(a.limits.watchdog_periods for a in cfg.axes) * period
        if cfg.bus.sync == "external":
            return ExternalSync(self.network, canopen_axes, timeout)
        if cfg.run.time == "lockstep":
            # the answers' wait is the transport's, not the emulated time's: at least the watchdog
            # in seconds (3 periods of 0.4 ms expired before socketcand's first answer came)
            wait = max(timeout, min(a.limits.watchdog for a in cfg.axes))
            return WireLockstep(self.network, canopen_axes, wait)
        if cfg.bus.interface == "socketcan":
            return KernelSync(self.network, canopen_axes, period, timeout)
        return HostSync(self.network, canopen_axes, self.answer_budget)

    # --- running -------------------------------------------------------------------------------
    def start(self) -> None:
        """Set every axis up and enable it (in configuration order); on failure, nothing stays enabled."""
        reached = False  #: an axis was set up (its run directory tells what was done to it)
        probe = self._time_probe()
        try:
            watch = self.master_watch
            if watch is not None:  # before any NMT command or SDO: another master is refused
                watch.check(max(2.0 * self.period, 0.1))
            idle = self._idle()
            if idle is not None and probe is not None:
                idle = probe.sending(idle)
            for k, axis in enumerate(self.axes):
                if idle is not None and hasattr(axis, "idle"):
                    axis.idle = idle  # waiting for a drive lets emulated time pass
                reached = k > 0
                try:
                    axis.setup()
                except NodeSilent as exc:
                    raise NodeSilent(f"{exc}; `{self._scan_hint()}` lists the nodes that answer") from exc
            reached = True
            self._watch_axes()
            if probe is not None:  # a device keeping time the other way: refused before the enable
                probe.check(lockstep=self.cfg.run.time == "lockstep")
            if self.cfg.run.time == "realtime":
                # the loop's full collection before its first cycle, done before anything is
                # enabled: on a large heap it takes longer than a drive's communication-loss time
                # (a Modbus inverter's), and frozen objects are not traversed again (HostLoop.run)
                gc.collect()
                gc.freeze()
                self._frozen = True
            for axis, a in zip(self.axes, self.cfg.axes):
                axis.enable(timeout=self._wait(a.enable_timeout))
            # after setup: it waits for the TPDOs the axes map; after enable: no SYNC during setup
            self.pacing = self._pacing(self.period)
            if watch is not None and self.pacing.sends_sync:  # a SYNC heard now is a second producer's
                watch.watch_sync()
            self._bus_load()
        except BaseException as exc:
            if probe is not None:
                probe.close()
            self.signals.stopping()
            reason = f"setup failed: {exc}" if isinstance(exc, RigError) else "setup failed"
            self._thaw()
            for axis in self.axes:
                if isinstance(exc, OtherMaster):  # its drives are another master's: not even disabled
                    axis._forget()
                    axis._release()
                else:
                    axis.close()
            self._finish({"cycles": 0, "safe_stop_reason": reason, "run_dir": str(self.recorder.dir)})
            if isinstance(exc, (NodeSilent, OtherMaster)) and not reached:  # no device reached: no run
                shutil.rmtree(self.recorder.dir, ignore_errors=True)
                if self._made_output:
                    with contextlib.suppress(OSError):
                        Path(self.cfg.run.output).rmdir()  # only if empty
            raise
        self.loop = self._loop()

    def _watch_axes(self) -> None:
        """Every CANopen axis's supervision watches for another master's RPDOs to it (its own
        RPDO's COB-ID too, where the mapping put it elsewhere) and NMT commands."""
        watch = self.master_watch
        if watch is None:
            return
        for axis in self.axes:
            if isinstance(axis, CanopenAxis):
                rpdo = getattr(getattr(axis, "data", None), "rpdo", None)
                if rpdo is not None:
                    watch.add_rpdo(rpdo.cob_id, axis.node_id)
                axis.master_watch = watch

    def _scan_hint(self) -> str:
        """The ``rig scan`` line for this run's bus."""
        b = self.cfg.bus
        return scan_command(b.interface, b.channel, b.bitrate or None, b.host, b.port)

    def _loop(self) -> HostLoop:
        """The host loop over the set-up axes (what each measures is known now)."""
        cfg = self.cfg
        realtime = cfg.run.time == "realtime"
        guards = [
            AxisGuard(axis, a.limits, self.period, realtime=realtime) for axis, a in zip(self.axes, cfg.axes)
        ]
        split = realtime and self.pacing.sends_sync
        columns = HostLoop.columns(self.axes, self.law, self.wiring, split=split)
        self.recorder.begin(columns, describe_columns(columns, self.axes, self.law))
        return HostLoop(
            self.axes,
            guards,
            self.law,
            self.wiring,
            recorder=self.recorder,
            pacing=self.pacing,
            period=self.period,
            cycles=self.cycles,
            realtime=cfg.run.time == "realtime",
            stop_timeout=max(a.stop_timeout for a in cfg.axes),
            heartbeat=self._heartbeat(),
            on_stop=self.signals.stopping,
            held=self.signals.held,
            missed_sample=cfg.run.missed_sample,
            late_stop=cfg.run.late_stop,
            producers=self.producer_watch,
        )

    def _heartbeat(self) -> Callable[[int], None] | None:
        """The host's heartbeat where a CANopen axis watches it (``[bus] heartbeat`` > 0)."""
        bus = self.cfg.bus
        if bus.heartbeat <= 0.0 or not any(isinstance(a, CanopenAxis) for a in self.axes):
            return None
        return HostHeartbeat(self.network, bus.host_node, bus.heartbeat, self.period).beat

    def run(
        self, progress: Callable[[int], None] | None = None, live: LiveView | None = None
    ) -> dict[str, Any]:
        """Run the loop (``start()`` first), with ``live`` fed each recorded row; stop the live view,
        SYNC and the trace; close the recorder; the summary."""
        loop = self.loop
        if loop is None:
            raise RuntimeError("Session.run() before start()")
        summary: dict[str, Any] = {}
        if live is not None:
            self._watch(live)
        grant = None
        try:
            if self.cfg.run.time == "realtime":
                run = self.cfg.run
                ask = RealtimeRequest(run.rt_priority, run.rt_cpu, run.rt_lock_memory, run.rt_cpu_latency)
                grant = request(ask, receive_threads(self.network))
                loop.granted = grant.record() | ({"bus_load": self.bus_figures} if self.bus_figures else {})
                if grant.fifo:
                    loop.spin = 0.0  # sleeps to each deadline: no spin at real-time priority
            summary = loop.run(progress)
            said = missed_period(summary, self.period)
            if said:
                log.warning("%s", said)
        finally:
            if grant is not None:
                grant.release()
            if live is not None:
                self.recorder.live = None
                live.stop()
            self._frozen = False  # the loop's run unfroze the heap
            summary = summary or loop.summary()
            if self.signals.taken is not None:  # the command ends: its data, not the plot (0.5 s of CPU)
                self.recorder.PLOT = False
                summary.setdefault("warnings", []).append(
                    f"{self.signals.taken.reason}: no plot.png drawn (samples.csv holds every sample)"
                )
            self._finish(summary)
        return summary

    def _bus_load(self) -> None:
        """Real time over a CAN bus: the cycle's share of the bus (``rig.host.bus_load``), warned
        above the whole period, recorded in the summary (``realtime.bus_load``)."""
        axes = [a for a in self.axes if isinstance(a, CanopenAxis)]
        if self.cfg.run.time == "realtime" and self.emulation is None and axes:
            self.bus_figures = bus_load(axes, self.period, self.cfg.bus.bitrate)
            warn_bus_load(self.bus_figures)

    def _watch(self, live: LiveView) -> None:
        """Start ``live`` on each axis's reference, measurement and command (``rig.live.channels``)."""
        rec = self.recorder
        modes = {a.name: a.mode for a in self.axes}
        live.start(channels_of(rec.columns, rec.docs, self.cfg.controller.reads, modes), rec.dir.name)
        rec.live = live.rows

    def _finish(self, summary: dict[str, Any]) -> None:
        self.pacing.close()
        self._detach_trace()
        self.recorder.close(summary)

    def _thaw(self) -> None:
        """Undo ``start``'s ``gc.freeze`` where the loop's run has not (it unfreezes at its end)."""
        if self._frozen:
            self._frozen = False
            gc.unfreeze()

    def close(self) -> None:
        """Disable and release every axis, the bus and the emulated world (idempotent); then the
        previous signal handlers."""
        self.signals.stopping()
        try:
            self._close()
        finally:
            self.signals.restore()

    def _close(self) -> None:
        self._thaw()
        if self.producer_watch is not None:
            self.producer_watch.close()
        if self.master_watch is not None:
            self.master_watch.close()
        for axis in self.axes:
            axis.close()
        recorder = getattr(self, "recorder", None)
        if recorder is not None and not recorder.closed:
            self._finish({"cycles": 0, "safe_stop_reason": "not run", "run_dir": str(recorder.dir)})
        if self._bus is not None:
            try:
                self.network.disconnect()
            except Exception as exc:  # the bus was lost: its error is in the summary already
                log.warning("the bus did not close cleanly: %s", exc)
            self._bus = None
        if self.emulation is not None:
            self.emulation.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        self.close()
        if kind is None:  # the run a signal cut short is the command's last
            self.signals.pass_on(None if self.loop is None else self.loop.stop_confirmed, self.recorder.dir)
