"""Benchmarks of the parts: microseconds per controller and plant step, physics steps/s, identification.

Each figure is the best of several repeats of N calls with changing inputs,
timed with ``time.perf_counter``; the loop's own overhead is included, so the
figures are what a host loop pays.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable

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
from rig.laws import drives_paper as drives
from rig.papers.dismc import dismc_laws

__all__ = ["Figure", "bench_controllers", "bench_identify", "bench_physics", "bench_plant", "rate"]

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
    a_m, b_m = drives.A_M, drives.B_M
    servo = design_dtsm(
        A=[[0.0, 1.0], [0.0, -a_m]], b=[0.0, -b_m], dt=drives.T_SERVO, lam=drives.LAMBDA_SERVO
    )
    speed = design_dtsm(A=[[-a_m]], b=[b_m], dt=1e-3, lam=-1.0)
    dtsm2 = DTSM(DTSMParams(design=servo, law="bounded", sigma=10.0))
    dtsm1c = DTSM(DTSMParams(design=speed, law="deadbeat"), FirstOrderCompensator(0.5, 1e-3))
    dtsm1c2 = DTSM(DTSMParams(design=speed, law="deadbeat"), SecondOrderCompensator(1e-3))
    idtsm = IDTSM(IDTSMParams(a=-a_m, b=b_m, dt=1e-3, lam=drives.LAMBDA_IDTSM))
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
    full = DCMotor(DCMotorParams.from_am_bm(a_m=drives.A_M, b_m=drives.B_M), dt=1e-4)
    reduced = ReducedDCMotor(a_m=drives.A_M, b_m=drives.B_M, dt=1e-3)
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
    """Microseconds per ``step`` of each controller (target <= 5 us).

    Parameters
    ----------
    n : int, optional
        Steps a run.
    repeats : int, optional
        Runs (the best taken).

    Returns
    -------
    list[Figure]
        us/step of each controller.
    """
    return _run(_controllers(), n, repeats)


def bench_plant(*, n: int = 100_000, repeats: int = 5) -> list[Figure]:
    """Microseconds per exact ZOH step of the plant models.

    Parameters
    ----------
    n : int, optional
        Steps a run.
    repeats : int, optional
        Runs (the best taken).

    Returns
    -------
    list[Figure]
        us/step of each plant.
    """
    return _run(_plants(), n, repeats)


def rate(fn: Callable[[], object], n: int, repeats: int) -> float:
    """Best calls per second of ``fn()`` over ``repeats`` runs of ``n`` calls, after one call
    outside the timing (a JIT compile, such as the induction motor's numba kernel, is not a step).

    Parameters
    ----------
    fn : Callable[[], object]
        What is timed.
    n : int
        Calls a run.
    repeats : int
        Runs.

    Returns
    -------
    float
        Calls/s, the best run's.
    """
    fn()
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, time.perf_counter() - t0)
    return n / best


def bench_physics(*, n: int = 200_000, cycles: int = 5_000, repeats: int = 3) -> list[Figure]:
    """Physics steps per second of each preset's axis (one SYNC period each), and lock-step
    emulator cycles per second (SYNC -> drive physics, limits, latch, TPDOs over the in-process bus).

    Parameters
    ----------
    n : int, optional
        Physics steps a run.
    cycles : int, optional
        Lock-step cycles a run.
    repeats : int, optional
        Runs.

    Returns
    -------
    list[Figure]
        Steps/s and cycles/s of each preset.
    """
    import canopen

    from drivers.maps import CIA402_EDS, cia
    from plant_emulator.lockstep import LockstepBench
    from plant_emulator.presets import PRESETS, build_preset

    figures: list[Figure] = []
    for name in PRESETS:
        devices, period = build_preset(name, canopen.Network())
        advance = functools.partial(devices[0].axis.advance, period, 0.0)  # type: ignore[attr-defined]
        steps = rate(advance, n // {"dc-servo": 1, "grid-converter": 4}.get(name, 100), repeats)
        figures.append({"name": f"{name}_physics_steps_per_s", "value": round(steps), "unit": "steps/s"})
    for name in PRESETS:
        bench = LockstepBench(name, {"u_line_rms": 0.0} if name == "grid-converter" else None)
        drive = canopen.RemoteNode(bench.devices[0].node_id, CIA402_EDS)
        bench.host.add_node(drive)
        if name == "dc-servo":
            drive.sdo[cia.MODES_OF_OPERATION].raw = int(cia.Mode.VOLTAGE)  # 0 V
        for cw in (cia.Controlword.SHUTDOWN, cia.Controlword.ENABLE_OPERATION):  # physics as in a run
            drive.sdo[cia.CONTROLWORD].raw = int(cw)
        bench.host.send_message(0, bytes([1, 0]))  # NMT start all
        figures.append(
            {
                "name": f"{name}_lockstep_cycles_per_s",
                "value": round(rate(bench.sync, cycles, repeats)),
                "unit": "cycles/s",
            }
        )
        bench.close()
    return figures


def bench_identify(*, seeds: int = 30, duration: float = 5.0) -> list[Figure]:
    """Accuracy of ``rig identify`` over ``seeds`` experiments on the dc-servo physics (3.4):
    4096 counts/rev, Coulomb friction 2 mN m, a one-sample command delay and Gaussian
    position noise of 0.3 counts before quantisation; PRBS 3 +- 2 V, 20 ms clock.

    Parameters
    ----------
    seeds : int, optional
        Experiments.
    duration : float, optional
        [s] of each.

    Returns
    -------
    list[Figure]
        The identified parameters' errors.
    """
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
        true = {"a_m": axis.motor.damping, "b_m": axis.motor.b_m}  # a_m with the viscous B/J in it
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
