"""Benchmarks: microseconds per controller step and per plant step.

Each figure is the best of several repeats of N calls with changing inputs,
timed with ``time.perf_counter``; the loop's own overhead is included, so the
figures are what a host loop pays.
"""

from __future__ import annotations

import functools
import gc
import itertools
import os
import time
from collections.abc import Callable
from typing import Any

from controllers.cascade import (
    TABLE_V_CURRENT,
    TABLE_V_POSITION,
    TABLE_V_SPEED,
    Cascade,
    CascadeLoop,
)
from controllers.compensators import FirstOrderCompensator, SecondOrderCompensator
from controllers.design import design_dtsm
from controllers.dismc import DISMC
from controllers.dq_current import ComplexVectorCurrentController, DqCurrentParams, DqPI, DqPIParams
from controllers.dtsm import DTSM, DTSMParams
from controllers.idtsm import IDTSM, IDTSMParams
from controllers.pi import PI, PIParams
from controllers.position_servo import PositionServo, PositionServoParams
from plant_emulator.dc_motor import DCMotor, DCMotorParams, ReducedDCMotor
from plant_emulator.rl_dq import ExactDqPlant, RLParams, StationaryRLConverter
from rig.reproduce import dismc_laws

__all__ = [
    "BENCHMARKS",
    "Figure",
    "bench_controllers",
    "bench_identify",
    "bench_loop",
    "bench_physics",
    "bench_plant",
]

Figure = dict[str, object]


def _time_per_call(fn: Callable[[float], object], n: int, repeats: int) -> float:
    """Best time per call [us] of ``fn(x)`` over ``repeats`` runs of ``n`` calls."""
    xs = [((i % 97) - 48) * 1e-3 for i in range(n)]
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        for x in xs:
            fn(x)
        best = min(best, time.perf_counter() - t0)
    return best / n * 1e6


def _controllers() -> dict[str, Callable[[float], object]]:
    servo = design_dtsm(A=[[0.0, 1.0], [0.0, -16.0]], b=[0.0, -680.0], dt=0.4e-3, lam=-15.0)
    speed = design_dtsm(A=[[-16.0]], b=[680.0], dt=1e-3, lam=-1.0)
    dtsm2 = DTSM(DTSMParams(design=servo, law="bounded", sigma=10.0))
    dtsm1c = DTSM(DTSMParams(design=speed, law="deadbeat"), FirstOrderCompensator(0.5, 1e-3))
    dtsm1c2 = DTSM(DTSMParams(design=speed, law="deadbeat"), SecondOrderCompensator(1e-3))
    idtsm = IDTSM(IDTSMParams(a=-16.0, b=680.0, dt=1e-3, lam=-50.0))
    ps = PositionServo(PositionServoParams(design=servo))
    loop1, loop2 = CascadeLoop(TABLE_V_CURRENT), CascadeLoop(TABLE_V_POSITION)
    casc = Cascade(CascadeLoop(TABLE_V_POSITION), CascadeLoop(TABLE_V_SPEED), CascadeLoop(TABLE_V_CURRENT))
    pi = PI(PIParams(kp=0.4443, ki=39.6, dt=5e-4, u_max=5.02, u_min=-5.02))
    laws = dismc_laws()
    dsmc, dismc, dismc_aw = (DISMC(laws[k]) for k in ("DSMC", "DISMC-LQR", "DISMC-AW-LQR"))
    xm = (0.0, 1.0)
    ts, w = 1.0 / 1350.0, 314.159
    cvc = ComplexVectorCurrentController(DqCurrentParams(r1=0.36, l1=6e-3, ts=ts, gamma=0.35))
    cvc_mid = ComplexVectorCurrentController(
        DqCurrentParams(r1=0.36, l1=6e-3, ts=ts, gamma=0.25, strategy="s-pwm-middle", u_max=400.0)
    )
    dq_pi = DqPI(DqPIParams(k_p=7.7, k_i=0.126, l1=6e-3, decouple=True, u_max=400.0))
    return {
        "dtsm_6.15a_2state": lambda x: dtsm2.step(x, -x),
        "dtsm_6.14_comp_6.30b": dtsm1c.step,
        "dtsm_6.14_comp_6.35": dtsm1c2.step,
        "idtsm_6.21": idtsm.step,
        "position_servo_7.30": lambda x: ps.step(x, 0.3 * x),
        "cascade_loop_current": lambda x: loop1.step(1.0, x),
        "cascade_loop_position": lambda x: loop2.step(1.0, x, -x),
        "cascade_3_loops": lambda x: casc.step(1.0, x, -x, 0.1 * x),
        "pi_antiwindup": pi.step,
        "dsmc_12": lambda x: dsmc.step((x, -x), xm),
        "dismc_34": lambda x: dismc.step((x, -x), xm),
        "dismc_aw_45": lambda x: dismc_aw.step((x, -x), xm),
        "dq_current_32_34": lambda x: cvc.step(1j, complex(x, -x), w * (1.0 + x)),
        "dq_current_32_37_limited": lambda x: cvc_mid.step(1j, complex(x, -x), w * (1.0 + x)),
        "dq_pi_decoupled": lambda x: dq_pi.step(1j, complex(x, -x), w * (1.0 + x)),
    }


def _plants() -> dict[str, Callable[[float], object]]:
    full = DCMotor(DCMotorParams.from_am_bm(a_m=16.0, b_m=680.0), dt=1e-4)
    reduced = ReducedDCMotor(a_m=16.0, b_m=680.0, dt=1e-3)
    exact = ExactDqPlant(RLParams(r1=0.36, l1=6e-3, ts=1.0 / 2700.0, m=0.5))
    fine = StationaryRLConverter(RLParams(r1=0.36, l1=6e-3, ts=1.0 / 2700.0, m=0.5), u_max=400.0)
    return {
        "dc_motor_3.4_step": full.step,
        "dc_motor_3.7_step": reduced.step,
        "rl_dq_29_step": lambda x: exact.step(complex(x, 1.0), 314.159),
        "rl_dq_29_step_varying_omega": lambda x: exact.step(complex(x, 1.0), 314.159 * (1.0 + x)),
        "rl_stationary_fine_step": lambda x: fine.step(complex(x, 1.0), 314.159, 300.0),
    }


def _run(table: dict[str, Callable[[float], object]], n: int, repeats: int) -> list[Figure]:
    return [
        {"name": name, "value": round(_time_per_call(fn, n, repeats), 3), "unit": "us/step"}
        for name, fn in table.items()
    ]


def bench_controllers(*, n: int = 100_000, repeats: int = 5) -> list[Figure]:
    """Microseconds per ``step`` of each controller (target <= 5 us)."""
    return _run(_controllers(), n, repeats)


def bench_plant(*, n: int = 100_000, repeats: int = 5) -> list[Figure]:
    """Microseconds per exact ZOH step of the plant models."""
    return _run(_plants(), n, repeats)


def _rate(fn: Callable[[], object], n: int, repeats: int) -> float:
    """Best calls per second of ``fn()`` over ``repeats`` runs of ``n`` calls."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, time.perf_counter() - t0)
    return n / best


def bench_physics(*, n: int = 200_000, cycles: int = 5_000, repeats: int = 3) -> list[Figure]:
    """Physics steps per second of each preset's axis (one SYNC period each), and lock-step
    emulator cycles per second (SYNC -> drive physics, limits, latch, TPDOs over the in-process bus)."""
    import canopen

    from drivers.maps import CIA402_EDS
    from plant_emulator.lockstep import LockstepBench
    from plant_emulator.presets import PRESETS, build_preset

    figures: list[Figure] = []
    for name in PRESETS:
        devices, period = build_preset(name, canopen.Network())
        advance = functools.partial(devices[0].axis.advance, period, 0.0)  # type: ignore[attr-defined]
        rate = _rate(advance, n // {"dc-servo": 1, "grid-converter": 4}.get(name, 100), repeats)
        figures.append({"name": f"{name}_physics_steps_per_s", "value": round(rate), "unit": "steps/s"})
    for name in PRESETS:
        bench = LockstepBench(name, {"u_line_rms": 0.0} if name == "grid-converter" else None)
        drive = canopen.RemoteNode(bench.devices[0].node_id, CIA402_EDS)
        bench.host.add_node(drive)
        if name == "dc-servo":
            drive.sdo[0x6060].raw = -1  # voltage mode, 0 V
        for cw in (0x06, 0x0F):  # enabled, so the physics runs as in a real run
            drive.sdo[0x6040].raw = cw
        bench.host.send_message(0, bytes([1, 0]))  # NMT start all
        figures.append(
            {
                "name": f"{name}_lockstep_cycles_per_s",
                "value": round(_rate(bench.sync, cycles, repeats)),
                "unit": "cycles/s",
            }
        )
        bench.close()
    return figures


def _steal_jiffies() -> int | None:
    """Total steal time of this machine's CPUs [jiffies] from /proc/stat (None where unknown)."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
        return int(fields[8]) if fields[0] == "cpu" and len(fields) > 8 else None
    except OSError:
        return None


def bench_loop(*, lockstep_s: float = 2.0, realtime_s: float = 3.0) -> list[Figure]:
    """The full chain per cycle: controller + CiA 402 driver + canopen + emulated drive + physics.

    Lock-step: cycles/s on the in-process bus (the demo's servo, recorder on).
    Real time: a 1 kHz loop against ``rig emulate`` in another process over socketcand
    (127.0.0.1): median, p99 and max period error, overruns, and the machine's steal time.
    """
    import dataclasses
    import math
    import os
    import re
    import tempfile

    from rig.config import BusConfig
    from rig.demo import demo_config
    from rig.process import spawn_rig, stop_rig
    from rig.run import prepare

    figures: list[Figure] = []
    with tempfile.TemporaryDirectory() as out:
        cfg = demo_config(out)
        rates = []
        for _ in range(3):  # best of three, as the other benchmarks: this machine is noisy
            session = prepare(cfg, emulate=True, duration=lockstep_s)
            summary = session.loop.run()
            session.close()
            rates.append(summary["cycles"] / summary["elapsed_s"])
        figures.append({"name": "lockstep_cycles_per_s", "value": round(max(rates)), "unit": "cycles/s"})
        figures.append(
            {"name": "lockstep_cycles_per_s_worst_of_3", "value": round(min(rates)), "unit": "cycles/s"}
        )

        proc, line = spawn_rig(
            "emulate", "--preset", "dc-servo", "--param", "period=0.001", "--socketcand-port", "0"
        )
        try:
            match = re.search(r":(\d+);", line)
            if match is None:
                raise RuntimeError("rig emulate did not start")
            rt = dataclasses.replace(
                cfg,
                reference=dataclasses.replace(cfg.reference, kind="constant", value=0.0),  # hold: timing only
                run=dataclasses.replace(cfg.run, time="realtime", period=0.001),
                bus=BusConfig(interface="socketcand", channel="can0", port=int(match.group(1))),
                limits=dataclasses.replace(cfg.limits, watchdog_periods=1000),
            )
            steal0 = _steal_jiffies()
            session = prepare(rt, emulate=False, duration=realtime_s)
            arrivals: list[float] = []
            session.network.subscribe(0x281, lambda can_id, data, ts: arrivals.append(time.perf_counter()))
            summary = session.loop.run()
            session.close()
            steal1 = _steal_jiffies()
        finally:
            stop_rig(proc, timeout=10)
    timing = summary["timing"]
    for key, name in (
        ("period_error_median_us", "median"),
        ("period_error_p99_us", "p99"),
        ("period_error_max_us", "max"),
    ):
        figures.append(
            {
                "name": f"realtime_1khz_period_error_{name}",
                "value": round(timing.get(key, float("nan")), 1),
                "unit": "us",
            }
        )
    figures.append({"name": "realtime_1khz_overruns", "value": summary["overruns"], "unit": "cycles"})
    gaps = [b - a for a, b in itertools.pairwise(arrivals)]
    figures.append(
        {
            "name": "realtime_1khz_max_tpdo_gap",
            "value": round(max(gaps, default=math.nan) * 1e3, 2),
            "unit": "ms",
        }
    )
    figures.append({"name": "realtime_1khz_cycles", "value": summary["cycles"], "unit": "cycles"})
    figures.append(
        {"name": "realtime_1khz_safe_stop", "value": summary["safe_stop_reason"] or "none", "unit": ""}
    )
    steal = (
        (steal1 - steal0) / os.sysconf("SC_CLK_TCK") * 1e3
        if steal0 is not None and steal1 is not None
        else float("nan")
    )
    figures.append({"name": "machine_steal_time_during_realtime", "value": round(steal, 1), "unit": "ms"})
    return figures


def bench_identify(*, seeds: int = 30, duration: float = 5.0) -> list[Figure]:
    """Accuracy of ``rig identify`` over ``seeds`` experiments on the dc-servo physics (3.4):
    4096 counts/rev, Coulomb friction 2 mN m, a one-sample command delay and Gaussian
    position noise of 0.3 counts before quantisation; PRBS 3 +- 2 V, 20 ms clock."""
    import math

    import canopen
    import numpy as np

    from plant_emulator.presets import build_preset
    from rig.identify import estimate, excitation

    errors: dict[str, list[float]] = {"a_m": [], "b_m": []}
    seconds = []
    for seed in range(seeds):
        devices, period = build_preset("dc-servo", canopen.Network(), {"coulomb": 0.002})
        axis = devices[0].axis  # type: ignore[attr-defined]
        true = {"a_m": axis.motor.a_m, "b_m": axis.motor.b_m}
        u = excitation("prbs", u0=3.0, amplitude=2.0, clock=0.02, dt=period, duration=duration, seed=seed)
        rng = np.random.default_rng(seed + 1)
        cpr = 4096 / (2 * math.pi)
        theta = np.empty(len(u))
        previous = u[0]
        for k, uk in enumerate(u):
            theta[k] = math.floor(axis.position * cpr + rng.normal(0.0, 0.3)) / cpr
            axis.set_command(-1, previous)  # one sample of delay
            axis.advance(period, k * period)
            previous = uk
        t0 = time.perf_counter()
        r = estimate(u, theta, period)
        seconds.append(time.perf_counter() - t0)
        errors["a_m"].append(abs(r.a_m / true["a_m"] - 1.0) * 100.0)
        errors["b_m"].append(abs(r.b_m / true["b_m"] - 1.0) * 100.0)
    figures: list[Figure] = []
    for name, e in errors.items():
        figures.append(
            {"name": f"identify_{name}_mean_abs_error", "value": round(float(np.mean(e)), 4), "unit": "%"}
        )
        figures.append(
            {"name": f"identify_{name}_worst_abs_error", "value": round(float(np.max(e)), 4), "unit": "%"}
        )
    figures.append(
        {"name": "identify_seconds_per_estimate", "value": round(float(np.mean(seconds)), 3), "unit": "s"}
    )
    figures.append({"name": "identify_data_seconds", "value": duration, "unit": "s"})
    return figures


def _rss_bytes() -> int:
    """Resident set size of this process [bytes] (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def bench_soak(*, cycles: int = 1_000_000, frame_loss: float = 0.01) -> list[Figure]:
    """The lock-step soak: the section VII.B servo over the emulated bus for ``cycles`` cycles with
    ``frame_loss`` of the frames lost. Memory is the RSS at 10 % of the run and at the end; the
    watchdog tolerates 10 lost TPDOs in a row, so a stop would be a real one. Not a test: run it
    with ``rig bench soak`` (about 2-3 minutes)."""
    import dataclasses
    import tempfile

    from rig.config import FaultsConfig
    from rig.demo import demo_config
    from rig.run import prepare

    with tempfile.TemporaryDirectory() as out:
        cfg = demo_config(out)
        period = 0.4e-3
        cfg = dataclasses.replace(
            cfg,
            run=dataclasses.replace(cfg.run, trace=False),
            reference=dataclasses.replace(cfg.reference, kind="constant", value=0.0),
            faults=FaultsConfig(frame_loss=frame_loss, seed=1),
            limits=dataclasses.replace(cfg.limits, watchdog_periods=10),
        )
        session = prepare(cfg, emulate=True, duration=cycles * period)
        law = session.loop.law
        rss: dict[str, int] = {}

        def measured(t: float, fb: Any) -> Any:
            k = round(t / period)
            if k in (cycles // 10, cycles - 1):  # the end is measured before the recorder's close
                gc.collect()
                rss["early" if k == cycles // 10 else "end"] = _rss_bytes()
            return law(t, fb)

        session.loop.law = measured
        t0 = time.perf_counter()
        summary = session.loop.run()
        elapsed = time.perf_counter() - t0
        session.close()
    early, end = rss.get("early", 0), rss.get("end", 0)
    growth = 100.0 * (end - early) / early if early and end else float("nan")
    return [
        {"name": "soak_cycles", "value": summary["cycles"], "unit": "cycles"},
        {"name": "soak_frame_loss", "value": frame_loss, "unit": ""},
        {"name": "soak_rss_at_10_percent", "value": round(rss.get("early", 0) / 2**20, 1), "unit": "MiB"},
        {"name": "soak_rss_at_last_cycle", "value": round(rss.get("end", 0) / 2**20, 1), "unit": "MiB"},
        {"name": "soak_memory_growth", "value": round(growth, 2), "unit": "%"},
        {"name": "soak_safe_stop", "value": summary["safe_stop_reason"] or "none", "unit": ""},
        {"name": "soak_wall_time", "value": round(elapsed, 1), "unit": "s"},
    ]


#: ``rig bench NAME`` -> function returning a list of {"name", "value", "unit"}.
BENCHMARKS: dict[str, Callable[[], list[Figure]]] = {
    "controllers": bench_controllers,
    "plant": bench_plant,
    "physics": bench_physics,
    "loop": bench_loop,
    "identify": bench_identify,
    "soak": bench_soak,
}
