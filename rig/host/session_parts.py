"""What a session (``rig.host.session.Session``) builds a run from, out of its configuration: the
plan that needs no bus (mode, timebase, cycles, law, wiring, output folder), the axes on the
transport, the recorder, the host loop over the set-up axes, its real-time grant and the live
view's feed. Nothing here
asks which transport it has: that is ``rig.host.transport``'s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from drivers.base import AxisDriver
from rig.config import RigConfig
from rig.host.axes import open_axis
from rig.host.columns import describe_columns
from rig.host.control import Wiring, build_law, wiring_of
from rig.host.loop import HostLoop
from rig.host.loop_options import LoopOptions
from rig.host.pacing import Pacing
from rig.host.realtime import Grant, RealtimeRequest, request
from rig.host.recorder import Recorder, output_folder
from rig.host.safety import AxisGuard
from rig.host.signals import StopRequests
from rig.host.timebase import Timebase
from rig.host.transport import Transport
from rig.host.transports import check_transport
from rig.laws.base import Law
from rig.live.backend import Live
from rig.live.channels import channels_of

__all__ = ["RunPlan", "grant_realtime", "host_loop", "open_axes", "open_recorder", "plan_run", "watch_live"]


@dataclass(frozen=True)
class RunPlan:
    """What a run needs no bus for (`plan_run`)."""

    timebase: Timebase  #: the period and time mode, read once
    cycles: int  #: the cycles to run
    law: Law  #: the law the loop steps
    wiring: Wiring  #: which axes it reads and commands, and the profile axes


def plan_run(cfg: RigConfig, *, emulate: bool, duration: float | None, cycles: int | None) -> RunPlan:
    """What the run's mode needs of ``cfg``, its timebase, cycles, law and output folder: a bad
    value is one error and nothing is opened.

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

    Returns
    -------
    RunPlan
        The plan.

    Raises
    ------
    ValueError
        ``cycles`` below 1.
    """
    check_transport(cfg, emulate=emulate)
    tb = Timebase.of(cfg)
    if cycles is not None and cycles < 1:
        raise ValueError(f"cycles = {cycles!r}: must be >= 1")
    n = cycles or tb.cycles(cfg.run.duration if duration is None else duration)
    plan = RunPlan(tb, n, build_law(cfg, tb.period), wiring_of(cfg))
    output_folder(cfg.run.output, f"{cfg.source}: [run]")
    return plan


def open_axes(cfg: RigConfig, transport: Transport, timebase: Timebase, axes: list[AxisDriver]) -> None:
    """Open every axis of ``cfg`` on ``transport`` and attach it, each appended to ``axes`` as it
    opens (a failure part-way leaves those opened to close).

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    transport : Transport
        Where the axes are.
    timebase : Timebase
        The run's.
    axes : list[AxisDriver]
        Where the opened axes go.
    """
    for a in cfg.axes:
        spec = dataclasses.replace(transport.endpoint(a), mode_timeout=transport.wait(a.mode_timeout))
        axis = open_axis(
            spec, network=transport.network, period=timebase.period, bus=cfg.bus, realtime=timebase.realtime
        )
        axes.append(axis)
        transport.attach(axis)


def open_recorder(cfg: RigConfig, timebase: Timebase, *, emulate: bool) -> Recorder:
    """The run's recorder, flushed every 50 ms of run time (a killed host loses at most that), with
    the configuration written.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration.
    timebase : Timebase
        The run's (its period is written as ``resolved_period`` [s]).
    emulate : bool
        Written as ``emulate``.

    Returns
    -------
    Recorder
        The recorder, its columns not begun.
    """
    recorder = Recorder(cfg.run.output, cfg.run.name, flush_period=0.05, trace=cfg.run.trace)
    recorder.write_config(cfg.as_dict() | {"resolved_period": timebase.period, "emulate": emulate})
    return recorder


def host_loop(
    cfg: RigConfig,
    plan: RunPlan,
    axes: list[AxisDriver],
    *,
    transport: Transport,
    pacing: Pacing,
    recorder: Recorder,
    signals: StopRequests,
) -> HostLoop:
    """The host loop over the set-up axes (what each measures is known now), its columns begun.

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration (the axes' limits and stop timeouts, ``[run]``).
    plan : RunPlan
        The run's plan.
    axes : list[AxisDriver]
        Every axis, set up and enabled.
    transport : Transport
        Where they are (the heartbeat, another producer's watch).
    pacing : Pacing
        The transport's pacing.
    recorder : Recorder
        Where the rows go.
    signals : StopRequests
        The stop signals (the stop's start, the section a signal waits for).

    Returns
    -------
    HostLoop
        The loop, not run.
    """
    tb = plan.timebase
    guards = [AxisGuard(axis, a.limits, tb.period, realtime=tb.realtime) for axis, a in zip(axes, cfg.axes)]
    columns = HostLoop.columns(axes, plan.law, plan.wiring, split=tb.realtime and pacing.sends_sync)
    recorder.begin(columns, describe_columns(columns, axes, plan.law))
    options = LoopOptions(
        stop_timeout=max(a.stop_timeout for a in cfg.axes),
        heartbeat=transport.heartbeat(axes),
        on_stop=signals.stopping,
        held=signals.held,
        missed_sample=cfg.run.missed_sample,
        late_stop=cfg.run.late_stop,
        producers=transport.producers,
    )
    return HostLoop(
        axes,
        guards,
        plan.law,
        plan.wiring,
        recorder=recorder,
        pacing=pacing,
        timebase=tb,
        cycles=plan.cycles,
        options=options,
    )


def watch_live(live: Live, recorder: Recorder, cfg: RigConfig, axes: list[AxisDriver]) -> None:
    """Start ``live`` on each axis's reference, measurement and command (``rig.live.channels``) and
    feed it the recorder's rows.

    Parameters
    ----------
    live : Live
        The live view.
    recorder : Recorder
        The run's, its columns begun.
    cfg : RigConfig
        The loaded configuration (the axes the law reads).
    axes : list[AxisDriver]
        Every axis (its mode names its channels' units).
    """
    modes = {a.name: a.mode for a in axes}
    live.start(channels_of(recorder.columns, recorder.docs, cfg.controller.reads, modes), recorder.dir.name)
    recorder.live = live.rows


def grant_realtime(
    cfg: RigConfig, loop: HostLoop, transport: Transport, bus_figures: dict[str, Any]
) -> Grant | None:
    """A real-time run: what ``[run]`` asks of the system (``rig.host.realtime.request``) for the
    loop's thread and the transport's receive threads, recorded in the loop's summary; at real-time
    priority the loop sleeps to each deadline (no spin).

    Parameters
    ----------
    cfg : RigConfig
        The loaded configuration (``[run] rt_*``).
    loop : HostLoop
        The loop about to run.
    transport : Transport
        Its receive threads are asked for too.
    bus_figures : dict[str, Any]
        The cycle's share of a CAN bus (``Transport.bus_load``), recorded beside the grant.

    Returns
    -------
    Grant | None
        What was granted (``release()`` it after the run); None in lock-step.
    """
    if not loop.timebase.realtime:
        return None
    run = cfg.run
    ask = RealtimeRequest(run.rt_priority, run.rt_cpu, run.rt_lock_memory, run.rt_cpu_latency)
    grant = request(ask, transport.receive_threads())
    loop.granted = grant.record() | ({"bus_load": bus_figures} if bus_figures else {})
    if grant.fifo:
        loop.spin = 0.0
    return grant
