"""``rig bench loop``: the whole chain per cycle, against the bare protocol exchange.

Lock-step, in this process, each the median of ``repeats`` runs:

- ``lockstep_cycles_per_s``: the section VII.B servo (``rig demo``'s configuration and its
  whole 3 s run: law, CiA 402 driver, canopen, emulated drive, physics, recorder and CAN trace);
- ``lockstep_dyno_cycles_per_s``: ``examples/dyno_speed_load.toml`` (three nodes,
  two commanded, one read), its first 2 s;
- ``canopen_baseline_cycles_per_s``: one SYNC, one TPDO and one RPDO per cycle
  between a canopen ``RemoteNode`` and a ``LocalNode`` on the same synchronous
  in-process bus, one value decoded on each side, and nothing else: no drive-rig
  driver, no physics, no recording;
- ``lockstep_vs_canopen_ratio``: the first over the third.

Real time: a 1 kHz loop against ``rig emulate`` in another process over
socketcand (127.0.0.1): period error, overruns, the longest TPDO gap, steal time.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import canopen

from drivers.errors import ConfigError
from drivers.maps import CIA402_EDS, cia
from plant_emulator.lockstep import SyncHub, attach_network
from rig.bench.micro import Figure, rate
from rig.config import BusConfig, RigConfig, load_config, replace_axis
from rig.emulator.spawn import spawn_emulator, stop_rig
from rig.host.session import Session
from rig.papers.demo import demo_config

__all__ = ["DYNO_EXAMPLE", "bench_loop", "canopen_baseline", "lockstep_rate", "lockstep_runs"]

DYNO_EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "dyno_speed_load.toml"


def lockstep_rate(cfg: RigConfig, seconds: float) -> float:
    """Cycles/s of one lock-step run of ``cfg`` (emulated) for ``seconds`` of run time.

    A RuntimeError where the run did not end clean: a safe stop, a stop not confirmed, or a
    drive that reported a fault (EMCY) during the run or its stop.

    Parameters
    ----------
    cfg : RigConfig
        The rig (emulated).
    seconds : float
        [s] of run time.

    Returns
    -------
    float
        Cycles/s.

    Raises
    ------
    RuntimeError
        If the run did not end clean (its reason said).
    """
    with Session(cfg, emulate=True, duration=seconds) as session:
        session.start()
        summary = session.run()
        faults = [f"{a.name}: {a.fault}" for a in session.axes if a.fault is not None]
    if summary["safe_stop_reason"]:
        raise RuntimeError(f"the benchmark run stopped: {summary['safe_stop_reason']}")
    if faults or not summary["stop_confirmed"]:
        said = "; ".join(faults) or f"still turning: {summary['still_turning']}"
        raise RuntimeError(f"the benchmark run of {cfg.run.name} did not end clean: {said}")
    return float(summary["cycles"] / summary["elapsed_s"])


def canopen_baseline(cycles: int = 20_000, repeats: int = 3) -> float:
    """Cycles/s of the bare exchange (see the module docstring); the best of ``repeats``.

    Per cycle, through canopen's generic PDO path on both sides: the host sends SYNC; the
    device packs TPDO2 (position, velocity) from its object dictionary and sends it; the host
    decodes both values (``PdoVariable.raw``), encodes RPDO1 (controlword, target) and sends
    it; the device writes both values into its object dictionary.

    Parameters
    ----------
    cycles : int, optional
        Cycles a run.
    repeats : int, optional
        Runs.

    Returns
    -------
    float
        Cycles/s, the best run's.
    """
    hub = SyncHub()
    host, device = canopen.Network(), canopen.Network()
    attach_network(host, hub.bus(queue=False, channel="host"))
    attach_network(device, hub.bus(queue=False, channel="device"))
    remote, local = canopen.RemoteNode(1, CIA402_EDS), canopen.LocalNode(1, CIA402_EDS)
    host.add_node(remote)
    device.add_node(local)
    for maps in (remote.tpdo, remote.rpdo, local.tpdo, local.rpdo):
        maps.read(from_od=True)  # type: ignore[no-untyped-call]
    tpdo, received, sent = local.tpdo[2], remote.tpdo[2], remote.rpdo[1]
    applied = local.rpdo[1]
    sent.data = bytearray(6)

    def on_sync(can_id: int, data: bytearray, ts: float) -> None:
        tpdo.data = bytearray(b"".join(local.get_data(v.index, v.subindex) for v in tpdo.map))
        tpdo.transmit()

    def on_rpdo(can_id: int, data: bytearray, ts: float) -> None:
        for v in applied.map:
            local.set_data(v.index, v.subindex, v.get_data())

    device.subscribe(cia.COB_SYNC, on_sync)
    device.subscribe(applied.cob_id, on_rpdo)  # after canopen's own handler, which stores the frame

    def cycle() -> None:
        hub.clock += 1e-3
        host.sync.transmit()
        position, velocity = (v.raw for v in received.map)
        sent[0].raw, sent[1].raw = 0x0F, position - velocity
        sent.transmit()

    try:
        return rate(cycle, cycles, repeats)
    finally:
        for net in (host, device):
            if net.bus is not None:
                net.bus.shutdown()


def lockstep_runs(out: str, seconds: float) -> list[tuple[RigConfig, float]]:
    """The lock-step runs of the bench, (configuration, run time [s]): the servo and the dyno.

    The servo runs ``rig demo``'s whole run (3 s): its load is the emulator's own (``pulse``
    from 1.5 to 3 s), an active load that does not stop with the host, and cut at ``seconds``
    = 2 s it turned the disabled motor after the stop up to 0x6080 (6000 rpm = 628.3 rad/s,
    0.69 s later at 1000 rad/s^2): fault 0x8400, the drive's right reaction
    (docs/emulator.md). The dyno's load is the host's own command to its load machine, which
    the stop sets to 0 N m and quick-stops, so ``seconds`` of it end at rest.

    Parameters
    ----------
    out : str
        The runs' folder.
    seconds : float
        [s] of the dyno's run.

    Returns
    -------
    list[tuple[RigConfig, float]]
        (configuration, run time [s]) of the servo and the dyno.

    Raises
    ------
    ConfigError
        If the dyno's example is not there (not a source checkout).
    """
    servo = demo_config(out)
    if not DYNO_EXAMPLE.exists():
        raise ConfigError(f"rig bench loop runs {DYNO_EXAMPLE}: run it from a source checkout")
    dyno = dataclasses.replace(load_config(DYNO_EXAMPLE), run=dataclasses.replace(servo.run, name="dyno"))
    return [(servo, servo.run.duration), (dyno, seconds)]


def _lockstep(out: str, seconds: float, repeats: int) -> list[Figure]:
    (servo, servo_s), (dyno, dyno_s) = lockstep_runs(out, seconds)
    one = [lockstep_rate(servo, servo_s) for _ in range(repeats)]
    three = [lockstep_rate(dyno, dyno_s) for _ in range(repeats)]
    base = canopen_baseline()
    one_axis = statistics.median(one)
    return [
        {"name": "lockstep_cycles_per_s", "value": round(one_axis), "unit": "cycles/s"},
        {
            "name": "lockstep_cycles_per_s_min_max",
            "value": f"{min(one):.0f}-{max(one):.0f}",
            "unit": "cycles/s",
        },
        {"name": "lockstep_dyno_cycles_per_s", "value": round(statistics.median(three)), "unit": "cycles/s"},
        {"name": "lockstep_dyno_min_max", "value": f"{min(three):.0f}-{max(three):.0f}", "unit": "cycles/s"},
        {"name": "canopen_baseline_cycles_per_s", "value": round(base), "unit": "cycles/s"},
        {"name": "lockstep_vs_canopen_ratio", "value": round(one_axis / base, 3), "unit": ""},
    ]


def _steal_jiffies() -> int | None:
    """Total steal time of this machine's CPUs [jiffies] from /proc/stat (None where unknown)."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
        return int(fields[8]) if fields[0] == "cpu" and len(fields) > 8 else None
    except OSError:
        return None


def _realtime(out: str, seconds: float) -> list[Figure]:
    proc, port = spawn_emulator("--preset", "dc-servo", "--param", "period=0.001")
    try:
        cfg = demo_config(out)
        rt = dataclasses.replace(
            cfg,
            reference=dataclasses.replace(cfg.reference, kind="constant", value=0.0),  # hold: timing only
            run=dataclasses.replace(cfg.run, time="realtime", period=0.001),
            bus=BusConfig(interface="socketcand", channel="can0", port=port),
        )
        rt = replace_axis(rt, "motor", limits={"watchdog_periods": 1000})
        steal0 = _steal_jiffies()
        arrivals: list[float] = []
        with Session(rt, emulate=False, duration=seconds) as session:
            session.start()
            session.transport.network.subscribe(
                cia.COB_TPDO[1] + 1, lambda can_id, data, ts: arrivals.append(time.perf_counter())
            )
            summary = session.run()
        steal1 = _steal_jiffies()
    finally:
        stop_rig(proc, timeout=10)
    steal = (
        (steal1 - steal0) / os.sysconf("SC_CLK_TCK") * 1e3
        if steal0 is not None and steal1 is not None
        else math.nan
    )
    return _realtime_figures(summary, arrivals, steal)


def _realtime_figures(summary: dict[str, Any], arrivals: list[float], steal: float) -> list[Figure]:
    """The real-time run's figures from its summary, the drive's TPDO arrival times [s] and the
    machine's steal time meanwhile [ms]."""
    timing = summary["timing"]
    gaps = [b - a for a, b in itertools.pairwise(arrivals)]
    figures: list[Figure] = [
        {
            "name": f"realtime_1khz_period_error_{name}",
            "value": round(timing.get(key, math.nan), 1),
            "unit": "us",
        }
        for key, name in (
            ("period_error_median_us", "median"),
            ("period_error_p99_us", "p99"),
            ("period_error_max_us", "max"),
        )
    ] + [
        {  # the host's response: its SYNC to the RPDOs it sends in answer (rig.host.loop)
            "name": f"realtime_1khz_response_{name}",
            "value": round(timing.get(f"response_{name}_us", math.nan), 1),
            "unit": "us",
        }
        for name in ("median", "p99", "max")
    ]
    return [
        *figures,
        {"name": "realtime_1khz_overruns", "value": summary["overruns"], "unit": "cycles"},
        {
            "name": "realtime_1khz_max_tpdo_gap",
            "value": round(max(gaps, default=math.nan) * 1e3, 2),
            "unit": "ms",
        },
        {"name": "realtime_1khz_cycles", "value": summary["cycles"], "unit": "cycles"},
        {"name": "realtime_1khz_safe_stop", "value": summary["safe_stop_reason"] or "none", "unit": ""},
        {"name": "machine_steal_time_during_realtime", "value": round(steal, 1), "unit": "ms"},
    ]


def bench_loop(*, lockstep_s: float = 2.0, realtime_s: float = 3.0, repeats: int = 3) -> list[Figure]:
    """The full chain per cycle: lock-step cycles/s (one axis, the dyno, the bare canopen exchange)
    and a 1 kHz real-time loop against rig emulate in another process.

    ``lockstep_s`` [s]: the dyno's run (the servo runs its own 3 s, ``lockstep_runs``); each
    lock-step run must end clean (``lockstep_rate``), or the bench stops with a RuntimeError.

    Parameters
    ----------
    lockstep_s : float, optional
        [s] of each lock-step run.
    realtime_s : float, optional
        [s] of the real-time run.
    repeats : int, optional
        Runs of each.

    Returns
    -------
    list[Figure]
        The figures.
    """
    with tempfile.TemporaryDirectory() as out:
        figures = _lockstep(out, lockstep_s, repeats)
        return figures + _realtime(out, realtime_s)
