"""``rig reproduce drives``: the drives paper's experiments, designed, simulated and run over the bus.

Six parts, one per key of the JSON document:

- ``design``: the delta model and sliding vector of the DC servo, (7.31), against the printed ones;
- ``table_v``: the three loops of Table V, the design (6.16)-(6.19) against the printed k_s, c_s
  (position row: lambda = -25 1/s; current row: printed k_eq truncated; speed row: its printed
  c_s, k_eq do not follow from a_w, b_w and are used as printed, ``controllers.cascade``);
- ``speed_loop``: Figs. 9-10. The text of section VII.A, where they belong, is missing; they are
  run on the DC platform of section VII.B, (3.5) with a_m = 16 1/s, b_m = 680 rad/(V s^2),
  T = 0.4 ms, under f(t) = 5 h(t-2) sin(5t) V in the control channel and a 100 rad/s speed step
  at t = 0, with the DTSM (6.15a) (sigma = 10 V, c_delta = 1/b_delta) alone, with the
  compensator (6.30b) for alpha = 0.1, 0.5, 1 and with (6.35). ``error_amplitude`` is half the
  peak-to-peak of the speed error over 2.5-5 s; ``theory`` is what the delta-model analysis
  predicts for a sinusoid through the switching-function dynamics, ``speed_error_theory``;
- ``position_servo``: section VII.B, (7.30) with h = 16 and h = 0 and the sign law (6.8), as pure
  simulations (the DC motor (3.4), exact measurements) and over the emulated CAN bus (``rig
  run``'s Session, dc-servo preset, 4096-count encoder, lock-step, as ``rig demo``);
- ``im_speed``: section VII.C, the IDTSM (6.20)-(6.21) (Table IV) against the PI (Table III) on
  IM1 (Table II), speed step 100 rad/s at 0.3 s, under the load of section VII.D,
  T_L = 5 [h(t-2) - h(t-4) + h(t-8) sin(4 pi t)] N m; pure: the field-oriented mechanics
  J dw/dt = T - B w - T_L with the torque as commanded (ideal FOC); over the bus: the emulated
  dyno, the motor under test (IM1 under FOC, CST) and the load machine applying -T_L as two
  drives on one shaft;
- ``cascade``: section VII.D, the position/speed/current cascade of Table V (reconstructed (6.36))
  under the same load, 10 rad in 1 s from 0.3 s; pure: ``scenarios.cascade_run`` on (4.9)
  with its current loop; over the bus: the position and speed loops on the dyno, the drive's
  FOC in place of the current loop.

Chattering figures follow ``rig.report.metrics``: the amplitude is the RMS of the command increment in
the steady-state window, the count the sign alternations larger than one step of the feedback's
resolution can cause through the law (0 threshold for the pure simulations' exact measurements;
over the bus, the summary's ``chattering_threshold``, from the resolution the samples show), the
sign-law share the part of the window's cycles the law spent outside its linear region (NaN for
the PI, which has none).
"""

from __future__ import annotations

import cmath
import math
import tempfile
from collections.abc import Callable
from typing import Any

import numpy as np

from controllers.cascade import TABLE_V_CURRENT, TABLE_V_POSITION, TABLE_V_SPEED, CascadeLoopParams
from controllers.design import design_dtsm
from rig.config import rig_config
from rig.laws import drives_paper as drives
from rig.papers.demo import DEMO_LOAD, demo_doc
from rig.papers.drives_dyno import cascade_part, im_part
from rig.papers.drives_setup import DRIVES_FIXED, DRIVES_PARAM_NAMES, EXACT, DrivesStudy, Signals, bus_run
from rig.papers.scenarios import Trajectory, position_servo_run, speed_loop_run
from rig.report.metrics import max_abs, rms, steady_chattering

__all__ = [
    "DRIVES_FIXED",
    "DRIVES_PARAM_NAMES",
    "DrivesStudy",
    "Signals",
    "drives_study",
    "speed_error_theory",
]

#: (7.31) and the text after it, as printed
PRINTED_7_31 = {
    "A_delta": [[0.0, 0.9968], [0.0, -15.9489]],
    "b_delta": [-0.13571, -677.828635],
    "c_delta": [-0.0221, -0.0015],
    "c_delta_A_delta": [0.0, 0.0015],
}
#: Table V as printed: a, b of each plant and the k_s (k_eq), c_s of its controller
PRINTED_TABLE_V: dict[str, dict[str, Any]] = {
    "current": {"a": -233.8936, "b": 42.8992, "k_s": [-5.4521], "c_s": [0.0236]},
    "speed": {"a": -0.6286, "b": 340.7439, "k_s": [-0.0015], "c_s": [0.0025]},
    "position": {"a": -500.0, "b": 500.0, "k_s": [0.0, -0.9373], "c_s": [0.0627, 0.0025]},
}
#: The speed-loop study's compensators: (name, compensator, alpha)
SPEED_CASES: tuple[tuple[str, str, float | None], ...] = (
    ("DTSM (6.15a)", "none", None),
    ("DTSM + (6.30b) alpha=0.1", "first", 0.1),
    ("DTSM + (6.30b) alpha=0.5", "first", 0.5),
    ("DTSM + (6.30b) alpha=1", "first", 1.0),
    ("DTSM + (6.35)", "second", None),
)


def speed_error_theory(
    compensator: str,
    alpha: float | None,
    *,
    a_m: float = drives.A_M,
    b_m: float = drives.B_M,
    dt: float = drives.T_SERVO,
    amplitude: float = 5.0,
    omega: float = 5.0,
) -> float:
    """Amplitude [rad/s] of the speed error the delta-model analysis predicts for
    f = ``amplitude`` sin(``omega`` t) [V] in the control channel of (3.5).

    d_k of (6.22a), normalised so that delta x = a_delta x + b_delta (u + d), has the amplitude
    F |int_0^T e^{-a_m tau} b_m e^{-j omega tau} dtau| / (T b_delta). The switching function
    follows it through g(z) = H(z) d(z): (6.23) H = T z^-1 for the law alone (its linear mode,
    |d| < sigma); (6.34) H = T (z - 1) / (z (z - (1 - alpha))) with (6.30b); with (6.35) (as
    read in ``controllers.compensators``) g_{k+1} = T (d_k - 2 d_k-1 + d_k-2), H = T (z-1)^2 z^-3.
    The speed error is e = -x = -b_delta g (c_delta = 1/b_delta), so its amplitude is
    b_delta |H(e^{j omega T})| |d|.

    Parameters
    ----------
    compensator : str
        "none", "first" (6.30b) or "second" (6.35).
    alpha : float | None
        The first's gain (None otherwise).
    a_m, b_m : float, optional
        Of (3.5).
    dt : float, optional
        [s] the period T.
    amplitude : float, optional
        [V] of f.
    omega : float, optional
        [rad/s] of f.

    Returns
    -------
    float
        [rad/s] the amplitude.

    Raises
    ------
    ValueError
        If the compensator is unknown, or "first" lacks ``alpha``.
    """
    design = design_dtsm(A=[[-a_m]], b=[b_m], dt=dt, lam=-1.0)
    b_delta = float(design.b_delta[0])
    d_amp = _disturbance_amplitude(amplitude, omega, a_m=a_m, b_m=b_m, dt=dt, b_delta=b_delta)
    h = _switching_transfer(compensator, alpha, cmath.exp(1j * omega * dt), dt)
    return b_delta * abs(h) * d_amp


def _disturbance_amplitude(
    amplitude: float, omega: float, *, a_m: float, b_m: float, dt: float, b_delta: float
) -> float:
    """|d_k| of (6.22a) for f = ``amplitude`` sin(``omega`` t) [V]: F |int_0^T e^{-a_m tau} b_m
    e^{-j omega tau} dtau| / (T b_delta)."""
    # int_0^T e^{-(a_m + j omega) tau} dtau, closed form
    s = a_m + 1j * omega
    integral = b_m * (1.0 - cmath.exp(-s * dt)) / s
    return amplitude * abs(integral) / (dt * b_delta)


def _switching_transfer(compensator: str, alpha: float | None, z: complex, dt: float) -> complex:
    """H(z) of g(z) = H(z) d(z) at ``z`` for the law alone (6.23), with (6.30b) (6.34) or (6.35)."""
    if compensator == "none":
        return dt / z
    if compensator == "first":
        if alpha is None:
            raise ValueError("the first-order compensator needs alpha")
        return dt * (z - 1.0) / (z * (z - (1.0 - alpha)))
    if compensator == "second":
        return dt * (z - 1.0) ** 2 / z**3
    raise ValueError(f"compensator must be none, first or second, got {compensator!r}")


def _design_part() -> dict[str, Any]:
    d = design_dtsm(
        A=[[0.0, 1.0], [0.0, -drives.A_M]], b=[0.0, -drives.B_M], dt=drives.T_SERVO, lam=drives.LAMBDA_SERVO
    )
    return {
        "equation": "(7.31)",
        "a_m": drives.A_M,
        "b_m": drives.B_M,
        "T": drives.T_SERVO,
        "lambda": drives.LAMBDA_SERVO,
        "A_delta": [list(row) for row in d.A_delta],
        "b_delta": list(d.b_delta),
        "c_delta": list(d.c_delta),
        "c_delta_A_delta": list(d.c_delta_A_delta),
        "printed": PRINTED_7_31,
    }


def _table_v_part() -> list[dict[str, Any]]:
    loops: tuple[tuple[str, CascadeLoopParams, float], ...] = (
        ("current", TABLE_V_CURRENT, -1.0),
        ("speed", TABLE_V_SPEED, -1.0),
        ("position", TABLE_V_POSITION, -25.0),
    )
    rows = []
    for name, used, lam in loops:
        printed = PRINTED_TABLE_V[name]
        a, b = printed["a"], printed["b"]
        if name == "position":
            design = design_dtsm(A=[[0.0, 1.0], [0.0, a]], b=[0.0, b], dt=used.dt, lam=lam)
        else:
            design = design_dtsm(A=[[a]], b=[b], dt=used.dt, lam=lam)
        decision = {
            "current": "designed k_eq = -5.45217 printed truncated as -5.4521; used as printed",
            "speed": "c_s, k_eq do not follow from a_w, b_w by (6.16); used as printed (c_s b_delta = 0.85)",
            "position": "(6.16)-(6.19) with lambda = -25 1/s reproduce the printed k_s, c_s",
        }[name]
        rows.append(
            {
                "name": name,
                "T": used.dt,
                "a": a,
                "b": b,
                "lambda": lam if name == "position" else None,
                "k_s_designed": list(design.c_delta_A_delta),
                "c_s_designed": list(design.c_delta),
                "k_s_printed": printed["k_s"],
                "c_s_printed": printed["c_s"],
                "k_s_used": list(used.k_s),
                "c_s_used": list(used.c_s),
                "c_s_b_delta": float(np.dot(used.c_s, design.b_delta)),
                "kappa": used.kappa,
                "decision": decision,
            }
        )
    return rows


def _amplitude(tr: Trajectory, t0: float, t1: float) -> float:
    e = tr.error[tr.window(t0, t1)]
    return float((e.max() - e.min()) / 2.0) if e.size else math.nan


def _speed_part(study: DrivesStudy, plots: dict[str, list[Signals]]) -> list[dict[str, Any]]:
    rows = []
    for name, comp, alpha in SPEED_CASES:
        tr = speed_loop_run(
            compensator=comp,
            alpha=alpha if alpha is not None else 1.0,
            dt=drives.T_SERVO,
            t_end=study.speed_t_end,
            substeps=study.substeps,
            law="bounded",
            sigma=drives.SIGMA,
            speed_step=100.0,
        )
        rows.append(
            {
                "name": name,
                "alpha": alpha,
                "error_amplitude": _amplitude(tr, 2.5, 5.0),
                "theory": speed_error_theory(comp, alpha),
                "final_speed": float(tr.y[-1]),
            }
        )
        plots.setdefault("speed_loop", []).append(
            Signals(name, tr.t, {"omega_ref": tr.ref, "omega": tr.y, "g": tr.g})
        )
    return rows


def _servo_metrics(  # noqa: PLR0917 - a row's signals
    t: np.ndarray, e: np.ndarray, u: np.ndarray, sign_law: np.ndarray, settle: float, threshold: float
) -> dict[str, Any]:
    steady = t >= settle
    return {
        "rms_error": rms(e),
        "max_error": max_abs(e),
        "steady_state_error": float(np.mean(e[steady])) if steady.any() else math.nan,
        **steady_chattering(u[steady], sign_law[steady], threshold=threshold),
    }


def _servo_part(study: DrivesStudy, output: str, plots: dict[str, list[Signals]]) -> list[dict[str, Any]]:
    cases: tuple[tuple[str, str, float], ...] = (
        ("(7.30) h=16", "7.30", 16.0),
        ("(7.30) h=0", "7.30", 0.0),
        ("sign law (6.8)", "sign", drives.H),
    )
    rows = []
    for name, law, h in cases:
        tr = position_servo_run(
            load=DEMO_LOAD,
            full_motor=True,
            t_end=study.servo_t_end,
            h=h,
            law="relay" if law == "sign" else "7.30",
        )
        row = {"name": name, "law": law, "h": h if law == "7.30" else None, "over_bus": False}
        row |= _servo_metrics(tr.t, tr.error, tr.u, tr.extra["sign_law"], study.servo_settle, 0.0) | EXACT
        rows.append(row)
        plots.setdefault("position_servo", []).append(
            Signals(name, tr.t, {"theta_r": tr.ref, "theta": tr.y, "u": tr.u})
        )
        if not study.bus:
            continue
        doc = demo_doc(output)
        doc["run"] |= {"duration": study.servo_t_end, "name": f"drives-servo-{law}-h{h:g}"}
        doc["controller"] |= {"h": h, "law": law}
        summary, c = bus_run(rig_config(doc, "rig reproduce drives"))
        t, e = c["t"], c["reference"] - c["measurement"]
        row = {"name": name, "law": law, "h": h if law == "7.30" else None, "over_bus": True}
        threshold = summary["chattering_threshold"]
        row |= _servo_metrics(t, e, c["command"], c["sign_law"], study.servo_settle, threshold)
        row["chattering_threshold"] = summary["chattering_threshold"]
        row["safe_stop_reason"] = summary["safe_stop_reason"]
        rows.append(row)
        plots["position_servo"].append(
            Signals(
                f"{name} over the bus",
                t,
                {"theta_r": c["reference"], "theta": c["measurement"], "u": c["command"]},
            )
        )
    return rows


def drives_study(
    study: DrivesStudy, output: str | None = None, *, progress: Callable[[int, int], None] | None = None
) -> tuple[dict[str, Any], dict[str, list[Signals]]]:
    """The six parts of the reproduction (see the module docstring) and, per experiment
    (``speed_loop``, ``position_servo``, ``im_speed``, ``cascade``), the runs' signals to plot;
    ``progress(parts done, 6)`` after each part.

    The over-the-bus runs write their run directories under ``output`` (a temporary
    directory, removed at the end, when None).

    Parameters
    ----------
    study : DrivesStudy
        The settings.
    output : str | None, optional
        The runs' folder (None: none kept).
    progress : Callable[[int, int], None] | None, optional
        ``progress(parts done, 6)``.

    Returns
    -------
    tuple[dict[str, Any], dict[str, list[Signals]]]
        (results, experiment -> signals).
    """
    plots: dict[str, list[Signals]] = {}
    with tempfile.TemporaryDirectory(prefix="rig-drives-") as tmp:
        out = output or tmp
        parts: dict[str, Callable[[], Any]] = {
            "design": _design_part,
            "table_v": _table_v_part,
            "speed_loop": lambda: _speed_part(study, plots),
            "position_servo": lambda: _servo_part(study, out, plots),
            "im_speed": lambda: im_part(study, out, plots),
            "cascade": lambda: cascade_part(study, out, plots),
        }
        doc: dict[str, Any] = {}
        for name, part in parts.items():
            doc[name] = part()
            if progress is not None:
                progress(len(doc), len(parts))
    return doc, plots
