"""A run of a configured rig: the one public path from a configuration to a running host loop.

``Session(cfg, emulate=..., duration=... or cycles=...)`` composes a transport, the axes, a law and
a recorder (``rig.host.session_parts``: first what needs no bus, so a refusal opens nothing), and
moves nothing yet (``cfg`` was checked at load: nothing is checked again). ``start()`` sets every
axis up, enables it, takes the transport's pacing and makes the loop. ``run()`` runs the loop, then
stops SYNC, the trace's frames, and closes the recorder with the summary. ``close()`` disables and
releases every axis and closes the transport. The session never asks which transport it has. A
session is a context manager which, where a stop signal came during it (``rig.host.signals``),
raises it once closed: a study of many runs ends with the one the signal stopped. ``rig run``,
``rig identify``, the benchmarks and the fault suite all run through here.
"""

from __future__ import annotations

import contextlib
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
from rig.host.control import build_law
from rig.host.loop import HostLoop
from rig.host.loop_summary import missed_period
from rig.host.pacing import Pacing
from rig.host.session_parts import grant_realtime, host_loop, open_axes, open_recorder, plan_run, watch_live
from rig.host.signals import StopRequests
from rig.host.transport import Transport
from rig.host.transports import open_transport
from rig.host.viewer_priority import raise_viewer
from rig.live.backend import Live

__all__ = ["Session", "build_law", "run_config"]

log = logging.getLogger(__name__)


def run_config(
    cfg: RigConfig,
    *,
    emulate: bool,
    duration: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    live: Live | None = None,
    started: Callable[[list[AxisDriver]], None] | None = None,
) -> dict[str, Any]:
    """Build, start and run ``cfg``.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    emulate : bool
        The emulated world in this process (``--emulate``).
    duration : float | None
        [s] of the run (None: ``[run] duration``).
    progress : Callable[[int, int], None] | None
        ``progress(k, cycles)`` every 1 % of the run (None: not).
    live : Live | None
        Shows the rows as they come (None: no live view).
    started : Callable[[list[AxisDriver]], None] | None
        ``started(axes)`` once every axis is set up and enabled, before the first cycle.

    Returns
    -------
    dict[str, Any]
        The summary (``cycles``, ``rms_error``, ..., ``run_dir``).
    """
    with Session(cfg, emulate=emulate, duration=duration) as session:
        session.start()
        if started is not None:
            started(session.axes)
        n = session.cycles
        return session.run(None if progress is None else lambda k: progress(k, n), live=live)


class Session:
    """A run of ``cfg`` (module docstring).

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    emulate : bool
        The emulated world in this process (``--emulate``).
    duration : float | None
        [s] of the run (None: ``[run] duration``).
    cycles : int | None
        The cycles to run, instead of ``duration`` (None: from it).
    """

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
        # first what needs no bus (``plan_run``): a bad value is one error and nothing was opened
        plan = self.plan = plan_run(cfg, emulate=self.emulate, duration=duration, cycles=cycles)
        self.timebase, self.cycles = plan.timebase, plan.cycles
        # then the transport, the axes on it, the recorder
        transport = self.transport = open_transport(cfg, plan.timebase, emulate=self.emulate)
        open_axes(cfg, transport, plan.timebase, self.axes)
        self._made_output = not Path(cfg.run.output).exists()  #: the recorder makes the folder
        self.recorder = open_recorder(cfg, plan.timebase, emulate=self.emulate)
        self._tap = self.recorder.on_frame
        transport.add_tap(self._tap)  # the trace: every frame sent and received

    # --- running -------------------------------------------------------------------------------
    def start(self) -> None:
        """Set every axis up and enable it (in configuration order); on failure, nothing stays enabled.

        Raises
        ------
        NodeSilent
            A node that did not answer, with the ``rig scan`` line that lists those that do.
        """
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
        self.loop = host_loop(
            self.cfg,
            self.plan,
            self.axes,
            transport=transport,
            pacing=self.pacing,
            recorder=self.recorder,
            signals=self.signals,
        )

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

    def run(self, progress: Callable[[int], None] | None = None, live: Live | None = None) -> dict[str, Any]:
        """Run the loop (``start()`` first); stop the live view, SYNC and the trace; close the recorder.

        Parameters
        ----------
        progress : Callable[[int], None] | None
            ``progress(k)`` every 1 % of the cycles (None: not).
        live : Live | None
            Fed each recorded row (None: no live view).

        Returns
        -------
        dict[str, Any]
            The summary.

        Raises
        ------
        RuntimeError
            Before ``start()``.
        """
        loop = self.loop
        if loop is None:
            raise RuntimeError("Session.run() before start()")
        summary: dict[str, Any] = {}
        if live is not None:
            watch_live(live, self.recorder, self.cfg, self.axes)
        grant = None
        try:
            grant = grant_realtime(self.cfg, loop, self.transport, self.bus_figures)
            if grant is not None and live is not None and live.thread is not None:  # shares the GIL
                raise_viewer(grant, live.thread)
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
