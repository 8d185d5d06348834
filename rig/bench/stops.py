"""``rig bench stops``: false stops and timing of real-time runs across processes, under load.

``runs`` runs of ``seconds`` each of ``examples/dc_servo_position_rt.toml`` (the VII.B servo
with a lean process image) in real time at ``period`` (the example's limits and watchdog;
``[run] time = "realtime"``), each against a fresh ``rig emulate`` of the example's
``[emulator]`` (the dc-servo preset, its load given an end so the disabled shaft is not pulled
to over-speed between runs) at the same period in another process over socketcand
(127.0.0.1), while ``load`` busy processes (a pure-Python loop each, normal priority) load the
machine. Any safe stop is a false one: nothing is injected. Figures, over the runs: the false
stops (and why), the cycles, overruns and late cycles as a share of the cycles (the median and
the worst run), the p99 of the period error and of the response (the host's SYNC to its RPDOs;
the issue's bound is half the period), the medians and worst; the CPU time a hypervisor took
from the machine during each run's cycles (steal time, ``rig.host.realtime.cpu_stolen``: on a
virtual machine, stalls no priority inside it can prevent; the median and worst run); the load
average before and after; the scheduling the host and the emulator were granted
(``rig.host.realtime``); and the machine's own floor, measured first under the same load for
one run's length (``rig.bench.floor``: a loop that only sleeps to the same deadlines under the
host's scheduling, as cyclictest does: the periods it missed, its lateness p99 and max), and
its floor for a SYNC's answer across processes (``rig.bench.round_trip``: a frame's round trip
to an echo process under the emulator's scheduling, the median, p99 and max), and the steadiness
of its CPU's speed (``rig.bench.steadiness``: the same small work once a period, its median and
p99, the share of periods it took 1.5 times its median or more, and the longest run of them). A run
whose bus did not open (the socketcand handshake failed) is tried again and named under
``bus_not_opened``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from drivers.errors import CommunicationError
from rig.bench.floor import sleep_floor
from rig.bench.micro import Figure
from rig.bench.round_trip import round_trip_floor
from rig.bench.steadiness import cpu_steadiness
from rig.config import BusConfig, load_config
from rig.emulator.spawn import spawn_emulator_line, stop_rig
from rig.host.realtime import RealtimeRequest
from rig.host.session import Session

__all__ = ["EXAMPLE", "bench_stops"]

log = logging.getLogger(__name__)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position_rt.toml"
#: the example's load step (1.5 s) ended at 3 s: after the run it does not pull the disabled shaft
LOAD = "pulse:0.0346:1.5:3"


@contextlib.contextmanager
def busy(n: int) -> Iterator[None]:
    """``n`` processes spinning in Python at normal priority while the block runs."""
    procs = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"], stdin=subprocess.DEVNULL)
        for _ in range(n)
    ]
    try:
        yield
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def _run(out: str, seconds: float, period: float) -> tuple[dict[str, Any], str]:
    """One run: its summary, and what the emulator was granted (from its first line)."""
    cfg = load_config(EXAMPLE)
    params = {**cfg.emulator.params, "load": LOAD, "period": f"{period!r}"}
    proc, port, line = spawn_emulator_line(
        "--preset", cfg.emulator.preset, *(a for k, v in params.items() for a in ("--param", f"{k}={v}"))
    )
    granted = re.search(r"\((SCHED_[^)]*|normal scheduling[^)]*)\)", line)
    try:
        cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(cfg.run, time="realtime", period=period, output=out, trace="asc"),
            bus=BusConfig(interface="socketcand", channel="can0", port=port),
        )
        with Session(cfg, emulate=False, duration=seconds) as session:
            session.start()
            return session.run(), granted.group(1) if granted else "not reported"
    finally:
        stop_rig(proc, timeout=20)


@functools.cache
def lockstep_rms(seconds: float, period: float) -> float:
    """The example's rms error [rad] over ``seconds`` in lock-step with the emulated drive in this
    process (the same emulator parameters as the real-time runs'): the reference the runs' own
    rms error is compared with."""
    cfg = load_config(EXAMPLE)
    with tempfile.TemporaryDirectory() as out:
        cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(cfg.run, time="lockstep", period=period, output=out),
            emulator=dataclasses.replace(
                cfg.emulator, params={**cfg.emulator.params, "load": LOAD, "period": period}
            ),
        )
        with Session(cfg, emulate=True, duration=seconds) as session:
            session.start()
            return float(session.run()["rms_error"])


def _loadavg() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "unknown"


def bench_stops(
    *,
    runs: int = 20,
    seconds: float = 10.0,
    period: float = 0.001,
    loads: Sequence[int] = (0,),
    progress: Callable[[int, int], None] | None = None,
) -> list[Figure]:
    """See the module docstring; ``progress(run, runs)`` after each run. Several ``loads``: the
    figures of each, named ``load{N}_...``, measured alternately a run of each at a time.

    Parameters
    ----------
    runs : int, optional
        Runs (of each load).
    seconds : float, optional
        [s] of each run.
    period : float, optional
        [s] the SYNC period.
    loads : Sequence[int], optional
        Busy processes beside the run, one figure set each.
    progress : Callable[[int, int], None] | None, optional
        ``progress(run, runs)``.

    Returns
    -------
    list[Figure]
        The figures.
    """
    if len(loads) == 1:
        return _bench_load(runs=runs, seconds=seconds, period=period, load=loads[0], progress=progress)
    blocks: dict[int, list[list[Figure]]] = {load: [] for load in loads}
    done = 0
    for _ in range(runs):  # alternated: each load's runs in the same minutes as the others'
        for load in loads:
            blocks[load].append(_bench_load(runs=1, seconds=seconds, period=period, load=load))
            done += 1
            if progress is not None:
                progress(done, runs * len(loads))
    return [{**f, "name": f"load{load}_{f['name']}"} for load in loads for f in _merge(blocks[load], runs)]


def _merge(blocks: list[list[Figure]], runs: int) -> list[Figure]:
    """One load's single-run blocks as one: every ``_median``/``_worst`` figure over the runs (the
    median of the runs' values, and the worst), each floor figure the median of the floors measured
    beside them, false stops summed, the rest from the first."""
    out: list[Figure] = []
    first = blocks[0]
    by_name = [{str(f["name"]): f["value"] for f in reversed(b)} for b in blocks]  # the first of a name
    for f in first:
        name = str(f["name"])
        values = [b[name] for b in by_name if name in b]
        numbers = [float(v) for v in values if isinstance(v, (int, float))]
        given = [x for x in numbers if math.isfinite(x)]  # a stopped run's NaN is no figure
        if len(numbers) != len(values):
            out.append(f)
        elif name.endswith("_median") or name.startswith("floor"):  # the floors' median too
            out.append({**f, "value": round(statistics.median(given), 3) if given else math.nan})
        elif name.endswith("_worst"):
            out.append({**f, "value": max(given) if given else math.nan})
        elif name == "false_stops":
            out.append({**f, "value": int(sum(numbers))})
        elif name == "runs":
            out.append({**f, "value": runs})
        else:
            out.append(f)
    out = [f for f in out if f["name"] not in ("false_stop", "bus_not_opened")]
    out += [f for b in blocks for f in b if f["name"] in ("false_stop", "bus_not_opened")]
    return out


def _bench_load(
    *,
    runs: int,
    seconds: float,
    period: float,
    load: int,
    progress: Callable[[int, int], None] | None = None,
) -> list[Figure]:
    """The runs at one ``load``: the runs' figures, then the machine's floor with the PM QoS CPU
    latency request the runs hold and without it (``floor_`` and ``floor_asleep_``)."""
    summaries, granted, unopened = [], "", []
    before = _loadavg()
    with busy(load), tempfile.TemporaryDirectory() as out:
        # the machine's own, under the same load: with the runs' request, and without it
        floor = sleep_floor(period, seconds)
        asleep = sleep_floor(period, seconds, RealtimeRequest(cpu_latency=-1))
        trip = round_trip_floor(period, seconds)
        steady = cpu_steadiness(period, seconds)
        for n in range(runs):
            for _ in range(3):  # a run whose bus did not open is no stop: said, and tried again
                try:
                    summary, granted = _run(out, seconds, period)
                    break
                except CommunicationError as exc:
                    unopened.append(str(exc))
                    log.warning("run %d/%d: the bus did not open: %s", n + 1, runs, exc)
            else:
                raise CommunicationError(f"the bus did not open three times: {unopened[-1]}")
            summaries.append(summary)
            log.info("run %d/%d: %s", n + 1, runs, summary["safe_stop_reason"] or "no stop")
            if progress is not None:
                progress(n + 1, runs)
        after = _loadavg()
    figures = _figures(
        summaries,
        period=period,
        seconds=seconds,
        load=load,
        loadavg=(before, after),
        emulator=granted,
        reference=lockstep_rms(seconds, period),
    )
    figures += _floor_figures(floor) + _floor_figures(asleep, "floor_asleep") + _trip_figures(trip)
    figures += _steady_figures(steady)
    return figures + [{"name": "bus_not_opened", "value": reason, "unit": ""} for reason in unopened]


def _figures(
    summaries: list[dict[str, Any]],
    *,
    period: float,
    seconds: float,
    load: int,
    loadavg: tuple[str, str],
    emulator: str,
    reference: float,
) -> list[Figure]:
    stops = [s["safe_stop_reason"] for s in summaries if s["safe_stop_reason"]]
    cycles = [max(1, s["cycles"] + s["overruns"]) for s in summaries]
    rms = [float(s["rms_error"]) for s in summaries if math.isfinite(float(s.get("rms_error", math.nan)))]
    return [
        {"name": "period", "value": period * 1e6, "unit": "us"},
        {"name": "load", "value": load, "unit": "busy processes"},
        {"name": "loadavg_before", "value": loadavg[0], "unit": "1/5/15 min"},
        {"name": "loadavg_after", "value": loadavg[1], "unit": "1/5/15 min"},
        {"name": "host_scheduling", "value": _scheduling(summaries[0].get("realtime") or {}), "unit": ""},
        {"name": "emulator_scheduling", "value": emulator, "unit": ""},
        {"name": "runs", "value": len(summaries), "unit": f"runs of {seconds:g} s"},
        {"name": "false_stops", "value": len(stops), "unit": "runs"},
        *({"name": "false_stop", "value": reason, "unit": ""} for reason in stops),
        {"name": "cycles_median", "value": statistics.median(cycles), "unit": "cycles"},
        *_spread("overruns", [100.0 * s["overruns"] / c for s, c in zip(summaries, cycles)], PERCENT, 3),
        *_spread("late", [100.0 * s["late_cycles"] / c for s, c in zip(summaries, cycles)], PERCENT, 3),
        *_timing_figures(summaries),
        # the runs' rms error [mrad], against lock-step's (NaN for a run that stopped: rig.report)
        {"name": "rms_lockstep", "value": round(1e3 * reference, 3), "unit": "mrad (lock-step, same plant)"},
        *_spread("rms_error", [1e3 * x for x in rms], "mrad (runs that completed)", 3),
        *_spread("rms_ratio", [x / reference for x in rms], "x lock-step's (runs that completed)", 3),
        {"name": "response_bound", "value": period / 2 * 1e6, "unit": "us (half the period)"},
    ]


PERCENT = "% of cycles"


def _spread(name: str, values: list[float], unit: str, digits: int = 1) -> list[Figure]:
    """``name``_median and ``name``_worst of ``values`` (NaN, never 0, when no run gave it)."""
    if not values:
        return [{"name": f"{name}_{k}", "value": math.nan, "unit": unit} for k in ("median", "worst")]
    return [
        {"name": f"{name}_median", "value": round(statistics.median(values), digits), "unit": unit},
        {"name": f"{name}_worst", "value": round(max(values), digits), "unit": unit},
    ]


def _scheduling(host: dict[str, Any]) -> str:
    """What the host's run was granted, in one line (its summary's ``realtime``)."""
    latency = host.get("cpu_latency_us")
    return (
        f"{host.get('policy', '?')} {host.get('priority', 0)} (receive {host.get('receive_priority', 0)}), "
        f"CPU {host.get('cpu')}, memory {'locked' if host.get('memory_locked') else 'not locked'}, "
        f"{'CPU latency held at ' + str(latency) + ' us' if latency is not None else 'CPU may sleep'}, "
        f"bus read by the {host.get('bus_read_by')}"
    )


def _timing_figures(summaries: list[dict[str, Any]]) -> list[Figure]:
    """The runs' timing percentiles [us] and the hypervisor's steal [ms], median and worst."""

    def timing(key: str) -> list[float]:
        return [float(s["timing"].get(key, float("nan"))) for s in summaries]

    names = ["period_error_p99", "response_median", "response_p99", "drive_answer_median", "drive_answer_p99"]
    names += ["host_time_median", "host_time_p99", "host_time_max"]
    found = [f for name in names for f in _spread(name, timing(f"{name}_us"), "us")]
    stolen = [(s.get("realtime") or {}).get("cpu_stolen_s") for s in summaries]
    if None not in stolen:
        unit = "ms per run (the hypervisor's; 10 ms steps)"
        found += _spread("cpu_stolen", [1e3 * x for x in stolen if x is not None], unit, 0)
    return found


def _trip_figures(trip: dict[str, Any]) -> list[Figure]:
    """The machine's floor for a SYNC's answer across processes (``rig.bench.round_trip``)."""
    return [
        {"name": f"floor_round_trip_{key}", "value": round(trip["round_trip_us"][key], 1), "unit": "us"}
        for key in ("median", "p99", "max")
    ]


def _steady_figures(steady: dict[str, Any]) -> list[Figure]:
    """The steadiness of the machine's CPU speed (``rig.bench.steadiness``) as ``floor_cpu_`` figures."""
    work = steady["work_us"]
    return [
        {"name": "floor_cpu_work_median", "value": round(work["median"], 1), "unit": "us"},
        {"name": "floor_cpu_work_p99", "value": round(work["p99"], 1), "unit": "us"},
        {"name": "floor_cpu_slow", "value": round(100.0 * steady["slow_share"], 2), "unit": "% of periods"},
        {"name": "floor_cpu_longest_slow", "value": round(steady["longest_slow_ms"], 1), "unit": "ms"},
    ]


def _floor_figures(floor: dict[str, Any], name: str = "floor") -> list[Figure]:
    """The machine's floor (``rig.bench.floor``) as figures beside the runs', named ``name_...``."""
    late = floor["lateness_us"]
    stolen = floor["cpu_stolen_s"]
    return [
        {"name": f"{name}_scheduling", "value": floor["granted"], "unit": ""},
        {
            "name": f"{name}_missed",
            "value": round(100.0 * floor["missed"] / floor["periods"], 3),
            "unit": "% of periods",
        },
        {"name": f"{name}_lateness_p99", "value": round(late["p99"], 1), "unit": "us"},
        {"name": f"{name}_lateness_max", "value": round(late["max"], 1), "unit": "us"},
        *(
            [{"name": f"{name}_cpu_stolen", "value": round(1e3 * stolen), "unit": "ms"}]
            if stolen is not None
            else []
        ),
    ]
