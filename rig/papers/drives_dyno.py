"""Sections VII.C and VII.D of the drives paper for ``rig reproduce drives``: the IDTSM
(6.20)-(6.21) against the PI of Table III on IM1 (``im_part``), and the position/speed/current
cascade of Table V (``cascade_part``), each as a pure simulation and over the emulated dyno (the
motor under test and the load machine applying -T_L, two drives on one shaft). The module
docstring of ``rig.papers.drives_study`` says what each part's rows hold."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from controllers.idtsm import IDTSM, IDTSMParams
from controllers.pi import PI, PIParams
from drivers.profiles import parse_profile
from rig.config import rig_config
from rig.laws import drives_paper as drives
from rig.papers.drives_setup import EXACT, DrivesStudy, Signals, bus_run
from rig.papers.scenarios import cascade_run
from rig.report.metrics import max_abs, rms, steady_chattering

__all__ = ["cascade_part", "im_part", "im_speed_run"]

#: Table III's speed PI in torque units (examples/im_speed_pi.toml): K_p,w k_t, K_i,w k_t / T
PI_KP = 0.673  #: [N m s/rad]
PI_KI = 60.0  #: [N m/rad]
IM_TORQUE_LIMIT = 10.0  #: [N m] both speed laws' output limit
IM_DYNO_LIMIT = 12.0  #: [N m] the motor axis's command limit over the dyno
#: [N m s] the limit of the IDTSM's integrator "Int 1" of section VII.C (+-0.01); without it the
#: 100 rad/s step winds it up while the torque is at its limit: 58 % overshoot
IDTSM_G_LIMIT = 0.01
#: The dyno's encoder and drives: 16 bits per revolution (examples/dyno_speed_load.toml), a speed
#: quantum of 0.19 rad/s over 0.5 ms; 4096 counts would make it 3.1 rad/s
DYNO_COUNTS = 65536


def _load_of(study: DrivesStudy) -> Any:
    return parse_profile(drives.vii_d_load(study.load))


def _windows(t_end: float) -> tuple[float, float, float]:
    """(start of the error figures, steady window start, end): after the step; under the
    constant load of 2-4 s, its last second (the last quarter of a shorter run)."""
    return 1.0 if t_end > 2.0 else 0.5 * t_end, min(3.0, 0.75 * t_end), min(4.0, t_end)


def _im_metrics(  # noqa: PLR0917 - a row's signals
    t: np.ndarray,
    e: np.ndarray,
    u: np.ndarray,
    sign_law: np.ndarray | None,
    t_end: float,
    threshold: float,
    command_range: float = math.inf,
) -> dict[str, Any]:
    t0, s0, s1 = _windows(t_end)
    after = t >= t0
    steady = (t >= s0) & (t < s1)
    return {
        "rms_error": rms(e[after]),
        "max_error": max_abs(e[after]),
        "steady_state_error": float(np.mean(e[steady])) if steady.any() else math.nan,
        **steady_chattering(
            u[steady],
            None if sign_law is None else sign_law[steady],
            threshold=threshold,
            command_range=command_range,
        ),
    }


def im_speed_run(law: str, *, t_end: float, load: Any, dt: float = drives.T_SPEED) -> Signals:
    """IDTSM (6.20)-(6.21) (Table IV: lambda = -50 1/s; Int 1 limited to +-0.01) or the PI of
    Table III (``law`` "idtsm" or "pi") controlling IM1 under ideal FOC, the mechanics of (4.2)
    with Table II's J and B, J dw/dt = T - B w - T_L, the torque command held over each
    period (exact ZOH), a 100 rad/s step at 0.3 s; ``load(t)`` [N m] taken mid-period.

    Parameters
    ----------
    law : str
        "idtsm" or "pi".
    t_end : float
        [s].
    load : Any
        T_L [N m] of time [s].
    dt : float, optional
        [s] the period.

    Returns
    -------
    Signals
        The run's signals.
    """
    a = -drives.B_IM / drives.J_IM
    b = 1.0 / drives.J_IM
    ctl: IDTSM | PI
    if law == "idtsm":
        ctl = IDTSM(
            IDTSMParams(a=a, b=b, dt=dt, lam=drives.LAMBDA_IDTSM, g_limit=IDTSM_G_LIMIT, u0=IM_TORQUE_LIMIT)
        )
    else:
        ctl = PI(PIParams(kp=PI_KP, ki=PI_KI, dt=dt, u_max=IM_TORQUE_LIMIT, u_min=-IM_TORQUE_LIMIT))
    n = round(t_end / dt)
    t = np.arange(n) * dt
    phi = math.exp(a * dt)
    gain = (phi - 1.0) / a
    w = 0.0
    ref, y, u_out, tl, sign = (np.empty(n) for _ in range(5))
    for k in range(n):
        tk = k * dt
        w_r = 100.0 if tk >= 0.3 else 0.0
        u = ctl.step(w_r - w)
        torque_load = load(tk + 0.5 * dt)
        ref[k], y[k], u_out[k], tl[k] = w_r, w, u, torque_load
        sign[k] = 0.0 if getattr(ctl, "linear", True) else 1.0
        w = phi * w + gain * b * (u - torque_load)
    series = {"omega_ref": ref, "omega": y, "torque": u_out, "T_L": tl}
    return Signals(law, t, series | ({"sign_law": sign} if law == "idtsm" else {}))


def _dyno_doc(study: DrivesStudy, output: str, name: str, controller: dict[str, Any]) -> dict[str, Any]:
    load = -study.load
    return {
        "run": {"duration": study.im_t_end, "output": output, "name": name},
        "emulator": {
            "preset": "dyno",
            "params": {"motor": "im", "period": drives.T_SPEED, "counts_per_rev": DYNO_COUNTS},
        },
        "axis": [
            {
                "name": "motor",
                "kind": "cia402",
                "node_id": 1,
                "mode": "cst",
                "sync_rpdo": False,  # applied on receipt, as the pure simulation's torque
                "limits": {"command": IM_DYNO_LIMIT, "speed": 320.0, "current": 12.0},
            },
            {
                "name": "load",
                "kind": "cia402",
                "node_id": 3,
                "mode": "cst",
                "sync_rpdo": True,
                "profile": drives.vii_d_load(load),
                "limits": {"command": abs(load) * 1.2 + 0.1, "speed": 320.0},
            },
        ],
        "controller": {"reads": ["motor"], "commands": ["motor"], **controller},
    }


def im_part(study: DrivesStudy, output: str, plots: dict[str, list[Signals]]) -> list[dict[str, Any]]:
    """The IM speed part: IDTSM and PI on IM1 (Tables II-IV), their rows; the signals into ``plots``.

    Parameters
    ----------
    study : DrivesStudy
        The settings.
    output : str
        The runs' folder.
    plots : dict[str, list[Signals]]
        Experiment -> signals, added to.

    Returns
    -------
    list[dict[str, Any]]
        The rows.
    """
    rows = []
    load = _load_of(study)
    laws = (
        ("IDTSM (6.20)-(6.21), Table IV", "idtsm"),
        ("PI, Table III", "pi"),
    )
    for name, law in laws:
        sig = im_speed_run(law, t_end=study.im_t_end, load=load)
        e = sig.series["omega_ref"] - sig.series["omega"]
        row = {"name": name, "law": law, "over_bus": False}
        torque = sig.series["torque"]
        row |= _im_metrics(sig.t, e, torque, sig.series.get("sign_law"), study.im_t_end, 0.0) | EXACT
        rows.append(row)
        sig.name = name
        plots.setdefault("im_speed", []).append(sig)
        if study.bus:
            row, sig = _im_over_bus(study, output, name, law)
            rows.append(row)
            plots["im_speed"].append(sig)
    return rows


def _im_controller(law: str) -> dict[str, Any]:
    """The ``[controller]`` table of ``law`` ("idtsm" or "pi") on IM1 over the dyno."""
    if law == "idtsm":
        return {
            "kind": "idtsm-speed",
            "a": -drives.B_IM / drives.J_IM,
            "b": 1.0 / drives.J_IM,
            "lam": drives.LAMBDA_IDTSM,
            "g_limit": IDTSM_G_LIMIT,
            "u0": IM_TORQUE_LIMIT,
        }
    return {
        "kind": "pi-speed",
        "kp": PI_KP,
        "ki": PI_KI,
        "u_max": IM_TORQUE_LIMIT,
        "u_min": -IM_TORQUE_LIMIT,
    }


def _im_over_bus(study: DrivesStudy, output: str, name: str, law: str) -> tuple[dict[str, Any], Signals]:
    """``law``'s speed step on IM1 over the bus on the dyno: its row and its signals."""
    doc = _dyno_doc(study, output, f"drives-im-{law}", _im_controller(law))
    doc["reference"] = {"kind": "step", "value": 100.0, "start": 0.3}
    summary, c = bus_run(rig_config(doc, "rig reproduce drives"))
    row = {"name": name, "law": law, "over_bus": True}
    e = c["reference"] - c["measurement"]
    threshold, limit = summary["chattering_threshold"], 2.0 * IM_DYNO_LIMIT
    row |= _im_metrics(c["t"], e, c["command"], c.get("sign_law"), study.im_t_end, threshold, limit)
    row["chattering_threshold"] = summary["chattering_threshold"]
    row["safe_stop_reason"] = summary["safe_stop_reason"]
    signals = {
        "omega_ref": c["reference"],
        "omega": c["measurement"],
        "torque": c["command"],
        "T_L": -c["load.command"],
    }
    return row, Signals(f"{name} over the dyno", c["t"], signals)


def cascade_part(study: DrivesStudy, output: str, plots: dict[str, list[Signals]]) -> list[dict[str, Any]]:
    """The cascade part (section VII.D, Table V), its rows; the signals into ``plots``.

    Parameters
    ----------
    study : DrivesStudy
        The settings.
    output : str
        The runs' folder.
    plots : dict[str, list[Signals]]
        Experiment -> signals, added to.

    Returns
    -------
    list[dict[str, Any]]
        The rows.
    """
    load = _load_of(study)
    tr = cascade_run(t_end=study.im_t_end, load=load, move_start=0.3)
    name = "cascade (6.36*), Table V"
    row: dict[str, Any] = {"name": name, "law": "cascade", "over_bus": False}
    row |= _im_metrics(tr.t, tr.error, tr.extra["i_ref"], tr.extra["sign_law"], study.im_t_end, 0.0) | EXACT
    row["command_unit"] = "A (q-current reference)"
    rows = [row]
    plots.setdefault("cascade", []).append(
        Signals(
            name,
            tr.t,
            {
                "theta_r": tr.ref,
                "theta": tr.y,
                "omega_ref": tr.extra["omega_ref"],
                "omega": tr.extra["omega"],
                "i_ref": tr.extra["i_ref"],
                "i_q": tr.extra["i_q"],
            },
        )
    )
    if study.bus:
        row, sig = _cascade_over_bus(study, output, name)
        rows.append(row)
        plots["cascade"].append(sig)
    return rows


def _cascade_over_bus(study: DrivesStudy, output: str, name: str) -> tuple[dict[str, Any], Signals]:
    """The cascade's move on IM1 over the bus on the dyno: its row and its signals."""
    controller = {"kind": "cascade-position", "position_every": 2}
    doc = _dyno_doc(study, output, "drives-cascade", controller)
    doc["reference"] = {"kind": "smooth-move", "distance": 10.0, "duration": 1.0, "start": 0.3}
    summary, c = bus_run(rig_config(doc, "rig reproduce drives"))
    e = c["reference"] - c["measurement"]
    k_t = drives.B_W * drives.J_IM
    row: dict[str, Any] = {"name": name, "law": "cascade", "over_bus": True}
    threshold = summary["chattering_threshold"] / k_t
    row |= _im_metrics(c["t"], e, c["i_q_ref"], c["sign_law"], study.im_t_end, threshold)
    row["command_unit"] = "A (q-current reference)"
    row["chattering_threshold"] = summary["chattering_threshold"] / k_t
    row["safe_stop_reason"] = summary["safe_stop_reason"]
    signals = {
        "theta_r": c["reference"],
        "theta": c["measurement"],
        "omega_ref": c["omega_ref"],
        "omega": c["motor.velocity"],
        "i_ref": c["i_q_ref"],
    }
    return row, Signals(f"{name} over the dyno", c["t"], signals)
