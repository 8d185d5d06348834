"""A run of a configured rig: the one public path from a configuration to a running host loop.

``Session(cfg, emulate=..., duration=... or cycles=...)`` composes a transport, the axes, a law and
a recorder, and moves nothing yet (``cfg`` was checked at load: nothing is checked again). First
what needs no bus: what the run's mode needs of the file, the timebase (``rig.host.timebase``:
the period read once), the law and the profiles, the output folder as it is now; a refusal there
opens nothing. Then the transport (``rig.host.transport``: a CAN bus, none for Modbus only, or
with ``emulate`` the emulated world), the axis drivers on it, the recorder (the configuration,
then every frame the transport taps). ``start()`` sets every axis up, enables it, takes the
transport's pacing and makes the loop. ``run()`` runs the loop, then stops SYNC, the trace's
frames, and closes the recorder with the summary. ``close()`` disables and releases every axis
and closes the transport. The session never asks which transport it has. A session is a context
manager which, where a stop signal came during it (``rig.host.signals``), raises it once closed:
a study of many runs ends with the one the signal stopped. ``rig run``, ``rig identify``, the
benchmarks and the fault suite all run through here.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import logging
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from drivers.base import AxisDriver
from drivers.errors import NodeSilent, RigError
from drivers.master_watch import OtherMaster
from rig.config import RigConfig
from rig.host.axes import open_axis
from rig.host.columns import describe_columns
from rig.host.control import build_law, wiring_of
from rig.host.loop import HostLoop, LoopOptions
from rig.host.loop_summary import missed_period
from rig.host.pacing import Pacing
from rig.host.realtime import RealtimeRequest, request
from rig.host.recorder import Recorder, output_folder
from rig.host.safety import AxisGuard
from rig.host.signals import StopRequests
from rig.host.timebase import Timebase
from rig.host.transport import Transport
from rig.host.transports import check_transport, open_transport
from rig.live.channels import channels_of
from rig.live.view import LiveView

__all__ = ["Session", "build_law", "run_config"]

log = logging.getLogger(__name__)


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


class Session:
    """See the module docstring."""

    transport: Transport  #: where the axes are (``rig.host.transport``), from ``_build`` on

    def __init__(
        self, cfg: RigConfig, *, emulate: bool, duration: float | None = None, cycles: int | None = None
    ) -> None:
        self.cfg, self.emulate = cfg, emulate
        self.axes: list[AxisDriver] = []
        self._tap: Callable[[Any], None] | None = None  #: the trace's tap on the transport
        self.pacing: Pacing = Pacing()
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

    def _build(self, duration: float | None, cycles: int | None) -> None:
        cfg = self.cfg
        # first what needs no bus: a bad value is one error and nothing was opened
        check_transport(cfg, emulate=self.emulate)  # what the run's mode needs of the file
        tb = self.timebase = Timebase.of(cfg)
        if cycles is not None and cycles < 1:
            raise ValueError(f"cycles = {cycles!r}: must be >= 1")
        self.cycles = cycles or tb.cycles(cfg.run.duration if duration is None else duration)
        self.law, self.wiring = build_law(cfg, tb.period), wiring_of(cfg)
        output_folder(cfg.run.output, f"{cfg.source}: [run]")
        # then the transport, the axes on it, the recorder
        transport = self.transport = open_transport(cfg, tb, emulate=self.emulate)
        for a in cfg.axes:
            spec = dataclasses.replace(transport.endpoint(a), mode_timeout=transport.wait(a.mode_timeout))
            axis = open_axis(
                spec, network=transport.network, period=tb.period, bus=cfg.bus, realtime=tb.realtime
            )
            self.axes.append(axis)
            transport.attach(axis)
        self._made_output = not Path(cfg.run.output).exists()  #: the recorder makes the folder
        # flushed every 50 ms of run time: a killed host loses at most that
        self.recorder = Recorder(cfg.run.output, cfg.run.name, flush_period=0.05, trace=cfg.run.trace)
        self.recorder.write_config(cfg.as_dict() | {"resolved_period": tb.period, "emulate": self.emulate})
        self._tap = self.recorder.on_frame
        transport.add_tap(self._tap)  # the trace: every frame sent and received

    # --- running -------------------------------------------------------------------------------
    def start(self) -> None:
        """Set every axis up and enable it (in configuration order); on failure, nothing stays enabled."""
        transport, tb = self.transport, self.timebase
        reached = False  #: an axis was set up (its run directory tells what was done to it)
        probe = transport.time_probe(self.axes)
        try:
            transport.before_setup()  # before any NMT command or SDO: another master is refused
            idle = transport.idle()
            if idle is not None and probe is not None:
                idle = probe.sending(idle)
            for k, axis in enumerate(self.axes):
                if idle is not None:
                    axis.idle = idle  # waiting for a drive lets (emulated) time pass
                reached = k > 0
                try:
                    axis.setup()
                except NodeSilent as exc:
                    raise NodeSilent(f"{exc}; `{transport.scan_hint()}` lists the nodes that answer") from exc
            reached = True
            transport.after_setup(self.axes)
            if probe is not None:  # a device keeping time the other way: refused before the enable
                probe.check(lockstep=tb.lockstep)
            if tb.realtime:
                # the loop's full collection before its first cycle, done before anything is
                # enabled: on a large heap it takes longer than a drive's communication-loss time
                # (a Modbus inverter's), and frozen objects are not traversed again (HostLoop.run)
                gc.collect()
                gc.freeze()
                self._frozen = True
            for axis, a in zip(self.axes, self.cfg.axes):
                axis.enable(timeout=transport.wait(a.enable_timeout))
            # after setup: it waits for the TPDOs the axes map; after enable: no SYNC during setup
            self.pacing = transport.pacing(self.axes)
            self.bus_figures = transport.bus_load(self.axes)
        except BaseException as exc:
            if probe is not None:
                probe.close()
            self._setup_failed(exc, reached)
            raise
        self.loop = self._loop()

    def _setup_failed(self, exc: BaseException, reached: bool) -> None:
        """Nothing stays enabled; a run that reached no device leaves no run directory."""
        self.signals.stopping()
        reason = f"setup failed: {exc}" if isinstance(exc, RigError) else "setup failed"
        self._thaw()
        for axis in self.axes:
            if isinstance(exc, OtherMaster):  # its drives are another master's: not even disabled
                axis.abandon()
            else:
                axis.close()
        self._finish({"cycles": 0, "safe_stop_reason": reason, "run_dir": str(self.recorder.dir)})
        if isinstance(exc, (NodeSilent, OtherMaster)) and not reached:  # no device reached: no run
            shutil.rmtree(self.recorder.dir, ignore_errors=True)
            if self._made_output:
                with contextlib.suppress(OSError):
                    Path(self.cfg.run.output).rmdir()  # only if empty

    def _loop(self) -> HostLoop:
        """The host loop over the set-up axes (what each measures is known now)."""
        cfg, tb = self.cfg, self.timebase
        guards = [
            AxisGuard(axis, a.limits, tb.period, realtime=tb.realtime) for axis, a in zip(self.axes, cfg.axes)
        ]
        split = tb.realtime and self.pacing.sends_sync
        columns = HostLoop.columns(self.axes, self.law, self.wiring, split=split)
        self.recorder.begin(columns, describe_columns(columns, self.axes, self.law))
        return HostLoop(
            self.axes,
            guards,
            self.law,
            self.wiring,
            recorder=self.recorder,
            pacing=self.pacing,
            timebase=tb,
            cycles=self.cycles,
            options=LoopOptions(
                stop_timeout=max(a.stop_timeout for a in cfg.axes),
                heartbeat=self.transport.heartbeat(self.axes),
                on_stop=self.signals.stopping,
                held=self.signals.held,
                missed_sample=cfg.run.missed_sample,
                late_stop=cfg.run.late_stop,
                producers=self.transport.producers,
            ),
        )

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
            if self.timebase.realtime:
                run = self.cfg.run
                ask = RealtimeRequest(run.rt_priority, run.rt_cpu, run.rt_lock_memory, run.rt_cpu_latency)
                grant = request(ask, self.transport.receive_threads())
                loop.granted = grant.record() | ({"bus_load": self.bus_figures} if self.bus_figures else {})
                if grant.fifo:
                    loop.spin = 0.0  # sleeps to each deadline: no spin at real-time priority
            summary = loop.run(progress)
            said = missed_period(summary, self.timebase.period)
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

    def _watch(self, live: LiveView) -> None:
        """Start ``live`` on each axis's reference, measurement and command (``rig.live.channels``)."""
        rec = self.recorder
        modes = {a.name: a.mode for a in self.axes}
        live.start(channels_of(rec.columns, rec.docs, self.cfg.controller.reads, modes), rec.dir.name)
        rec.live = live.rows

    def _finish(self, summary: dict[str, Any]) -> None:
        self.pacing.close()
        tap, self._tap = self._tap, None
        if tap is not None:
            self.transport.remove_tap(tap)
        self.recorder.close(summary)

    def _thaw(self) -> None:
        """Undo ``start``'s ``gc.freeze`` where the loop's run has not (it unfreezes at its end)."""
        if self._frozen:
            self._frozen = False
            gc.unfreeze()

    def close(self) -> None:
        """Disable and release every axis and close the transport (idempotent); then the previous
        signal handlers."""
        self.signals.stopping()
        try:
            self._close()
        finally:
            self.signals.restore()

    def _close(self) -> None:
        self._thaw()
        transport: Transport | None = getattr(self, "transport", None)  #: None: it failed to open
        if transport is not None:
            transport.unwatch()
        for axis in self.axes:
            axis.close()
        recorder = getattr(self, "recorder", None)
        if recorder is not None and not recorder.closed:
            self._finish({"cycles": 0, "safe_stop_reason": "not run", "run_dir": str(recorder.dir)})
        if transport is not None:
            transport.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        self.close()
        if kind is None:  # the run a signal cut short is the command's last
            self.signals.pass_on(None if self.loop is None else self.loop.stop_confirmed, self.recorder.dir)
