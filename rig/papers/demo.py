"""``rig demo``: the DC position servo of section VII.B, designed and simulated.

Designs the DTSM from a_m = 16, b_m = 680, T = 0.4 ms, lambda = -15 (7.31),
runs (7.30) on the DC motor (3.4) through a smooth 0 -> 10 rad move with a
load step, and compares the integral (h = 16) with h = 0 and with the
discontinuous sign law; then runs the same servo over the emulated CAN bus
(``rig run`` with the dc-servo preset) and prints its metrics and run directory.
"""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TextIO

from controllers.design import DTSMDesign, design_dtsm
from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.presets import DcServoPreset
from rig.config import RigConfig, rig_config
from rig.host.session import run_config
from rig.identify import excitation
from rig.identify.experiment import experiment_config, identify_from_log, run_experiment
from rig.laws import drives_paper as drives
from rig.papers.scenarios import Trajectory, cascade_run, position_servo_run
from rig.report.metrics import chattering_amplitude, chattering_count, max_abs, rms, sign_law_share
from rig.report.summary import summary_lines

__all__ = ["DemoSummary", "demo_config", "demo_doc", "demo_summary", "run_demo"]

#: Disturbance of the load step, f = T_L / J [rad/s^2] of (7.28).
DEMO_LOAD = 1000.0


def _row(name: str, tr: Trajectory, settle: float) -> dict[str, Any]:
    steady = tr.window(settle)
    return {
        "controller": name,
        "max_tracking_error_rad": max_abs(tr.error[tr.window(0.0, 1.5)]),
        "rms_tracking_error_rad": rms(tr.error[tr.window(0.0, 1.5)]),
        "steady_state_error_rad": float(tr.error[steady].mean()),
        "u_max": max_abs(tr.u),
        # exact measurements: every alternation above rounding counts (docs/chattering.md)
        "chattering_steady": chattering_count(tr.u[steady]),
        "chattering_amplitude": chattering_amplitude(tr.u[steady]),
        "sign_law_share": sign_law_share(tr.extra["sign_law"][steady])
        if "sign_law" in tr.extra
        else math.nan,
    }


@dataclass(frozen=True)
class DemoSummary:
    """What ``rig demo`` measured."""

    design: DTSMDesign  #: the (7.31) design
    load_error_theory_rad: float  #: T c_2 f / c_1 for h = 0 [rad]
    rows: list[dict[str, Any]]  #: one metrics row per controller


def demo_summary() -> DemoSummary:
    """Run the demo scenarios and return the design and one metrics row per controller.

    Returns
    -------
    DemoSummary
        The design and one metrics row per controller.
    """
    design = design_dtsm(
        A=[[0.0, 1.0], [0.0, -drives.A_M]], b=[0.0, -drives.B_M], dt=drives.T_SERVO, lam=drives.LAMBDA_SERVO
    )

    def servo(**kw: Any) -> Trajectory:
        return position_servo_run(load=DEMO_LOAD, full_motor=True, t_end=3.0, **kw)

    rows = [
        _row("dtsm-7.30 h=16", servo(h=16.0), 2.5),
        _row("dtsm-7.30 h=0", servo(h=0.0), 2.5),
        _row("sign law (6.8)", servo(law="relay"), 2.5),
        _row(
            "cascade VII.D (6.36*)",
            cascade_run(t_end=4.0, load=lambda t: 5.0 if t >= 2.0 else 0.0),
            3.5,
        ),
    ]
    c1, c2 = design.c_delta
    expected = design.dt * c2 * DEMO_LOAD / c1
    return DemoSummary(design, expected, rows)


def demo_config(output: str = "runs", *, a_m: float = drives.A_M, b_m: float = drives.B_M) -> RigConfig:
    """The section VII.B servo over the emulated bus: dc-servo preset, voltage mode, (7.30)
    designed for the model a_m, b_m (the identified one in ``rig demo``).

    Parameters
    ----------
    output : str, optional
        The runs' folder.
    a_m : float, optional
        [1/s] the model's a_m.
    b_m : float, optional
        The model's b_m [rad/(V s^2)].

    Returns
    -------
    RigConfig
        The configuration.
    """
    return rig_config(demo_doc(output, a_m=a_m, b_m=b_m), "rig demo")


def demo_doc(output: str = "runs", *, a_m: float = drives.A_M, b_m: float = drives.B_M) -> dict[str, Any]:
    """``demo_config``'s configuration as the document a TOML file would give.

    Parameters
    ----------
    output : str, optional
        The runs' folder.
    a_m : float, optional
        [1/s] the model's a_m.
    b_m : float, optional
        The model's b_m [rad/(V s^2)].

    Returns
    -------
    dict[str, Any]
        The TOML document.
    """
    plant = DcServoPreset()  # T_L = J f with the J of the preset's motor (its B within a_m)
    load = DEMO_LOAD * DCMotorParams.from_am_bm(a_m=plant.a_m, b_m=plant.b_m, b=plant.friction).j
    doc: dict[str, Any] = {
        "run": {"duration": 3.0, "output": output, "name": "demo-dc-servo"},
        # the load ends with the run: an active load left on turns the disabled motor after it
        "emulator": {"preset": "dc-servo", "params": {"load": f"pulse:{load:.6g}:1.5:3"}},
        "axis": [
            {
                "name": "motor",
                "kind": "cia402",
                "node_id": 1,
                "mode": "voltage",
                "sync_rpdo": False,
                "limits": {
                    "command": 48.0,
                    "speed": 300.0,
                    "position_min": -1.0,
                    "position_max": 12.0,
                    "current": 30.0,
                },
            }
        ],
        "controller": {"kind": "position-servo", "a_m": a_m, "b_m": b_m, "u0": 48.0},
        "reference": {"kind": "smooth-move", "distance": 10.0, "duration": 1.0},
    }
    return doc


def run_demo(
    out: TextIO,
    *,
    output: str = "runs",
    progress: Callable[[int, int], None] | None = None,
    record: dict[str, Any] | None = None,
) -> int:
    """Print the demo to ``out``; ``progress(parts done, 3)`` after the simulations, the
    identification and the run over the bus; returns the exit code: 1 a simulation not finite,
    else the run's (0 done, 3 a safe stop, 4 its stop not confirmed).

    Parameters
    ----------
    out : TextIO
        Where it prints.
    output : str, optional
        The runs' folder.
    progress : Callable[[int, int], None] | None, optional
        ``progress(parts done, 3)``.
    record : dict[str, Any] | None, optional
        Filled with the same figures (``rig demo --json``): design, simulations, identified,
        run (its summary).

    Returns
    -------
    int
        0 done, 1 a simulation not finite, 3 a safe stop, 4 its stop not confirmed.
    """
    step = progress or (lambda k, n: None)
    doc: dict[str, Any] = {} if record is None else record
    s = demo_summary()
    step(1, 3)
    _print_simulations(out, s, doc)
    wire = _over_the_bus(out, output, step, doc)
    if importlib.util.find_spec("matplotlib") is None:
        out.write("  (no plot.png: it needs matplotlib, python -m pip install -e '.[plot]')\n")
    simulated_ok = all(math.isfinite(float(r["steady_state_error_rad"])) for r in s.rows)
    if not simulated_ok:
        return 1
    if wire["stop_confirmed"] is False:
        return 4
    return 0 if wire["safe_stop_reason"] is None else 3


def _print_simulations(out: TextIO, s: DemoSummary, doc: dict[str, Any]) -> None:
    """The simulations' part of the demo: the design, the move, and a row per controller (in
    ``doc`` too, as ``rig demo --json`` prints them)."""
    d = s.design
    doc["design"] = {"c_delta": list(d.c_delta), "c_delta_A_delta": list(d.c_delta_A_delta)}
    doc["load_error_theory_rad"] = s.load_error_theory_rad
    doc["simulations"] = [dict(r) for r in s.rows]
    out.write("drive-rig demo: DC position servo, section VII.B\n")
    out.write(f"  design (7.31): c_delta = {list(d.c_delta)}, c_delta A_delta = {list(d.c_delta_A_delta)}\n")
    out.write("  move 0 -> 10 rad in 1 s, load step f = T_L/J = 1000 rad/s^2 at 1.5 s\n")
    out.write(f"  theory, h = 0: e_1 = T c_2 f / c_1 = {s.load_error_theory_rad:.6f} rad\n\n")
    head = f"  {'controller':24s} {'max|e| rad':>11s} {'rms e rad':>11s} {'e_ss rad':>12s}"
    head += f" {'max|u|':>8s} {'chatter':>8s} {'du rms':>9s} {'sign %':>7s}\n"
    out.write(head)
    for r in s.rows:
        out.write(
            f"  {r['controller']:24s} {r['max_tracking_error_rad']:11.2e} {r['rms_tracking_error_rad']:11.2e}"
            f" {r['steady_state_error_rad']:12.3e} {r['u_max']:8.2f} {r['chattering_steady']:8d}"
            f" {r['chattering_amplitude']:9.2e} {100.0 * r['sign_law_share']:7.3g}\n"
        )
    out.write(
        "\n  chatter = sign alternations of the control increment du in steady state (t >= 2.5 s) larger\n"
        "  than one step of the feedback's resolution can cause through the law (exact here: every one\n"
        "  counts);\n"
        "  du rms = chattering amplitude, RMS of du; sign % = the steady state's cycles outside the\n"
        "  law's linear region ((6.8)'s sign term, (7.30b)'s sigma branch, a bound).\n"
        "  See docs/chattering.md.\n"
        "  (6.36*) is a documented reconstruction; u is in V, except the cascade (V at the q axis).\n"
    )


def _over_the_bus(
    out: TextIO, output: str, step: Callable[[int, int], None], doc: dict[str, Any]
) -> dict[str, Any]:
    """The demo's part over the emulated bus: the model identified, (7.31) designed from it and run
    (in ``doc`` too); the run's summary."""
    out.write("\nOver the emulated CAN bus (CiA 402 drive, voltage mode, 4096-count encoder, lock-step):\n")
    cfg = demo_config(output)
    u = excitation("prbs", u0=3.0, amplitude=2.0, clock=0.02, dt=drives.T_SERVO, duration=3.0, seed=1)
    ident = run_experiment(experiment_config(cfg, u, params={}), emulate=True)
    model = identify_from_log(ident["run_dir"])
    step(2, 3)
    doc["identified"] = {
        "a_m": model.a_m,
        "a_m_stderr": model.a_m_stderr,
        "b_m": model.b_m,
        "b_m_stderr": model.b_m_stderr,
        "delay_samples": model.delay_samples,
        "fit_percent": model.fit_percent,
        "run_dir": str(ident["run_dir"]),
    }
    out.write(
        f"  identify (PRBS 3 +- 2 V, 3 s): a_m = {model.a_m:.4f} +- {model.a_m_stderr:.1g} 1/s, "
        f"b_m = {model.b_m:.2f} +- {model.b_m_stderr:.1g}, delay {model.delay_samples}, "
        f"held-out fit {model.fit_percent:.1f} %\n"
    )
    out.write("  design (7.31) from the identified model, lambda = -15; run over the bus:\n")
    wire = run_config(demo_config(output, a_m=model.a_m, b_m=model.b_m), emulate=True)
    step(3, 3)
    doc["run"] = wire
    out.write("".join(f"  {line}\n" for line in summary_lines(wire)))
    out.write(
        "  (chattering over the run's second half, beyond what one step of the feedback's resolution\n"
        "  (one encoder count, one increment/s of 0x606C, measured in the samples) moves the command:\n"
        "  a one-count limit cycle is not counted; see docs/chattering.md)\n"
    )
    return wire
