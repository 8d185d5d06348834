"""``rig tune``: a law designed from an identification, with its margins on the measured plant.

The design (``controllers.tuning``) is made on the identified (3.5); the loop gain
L = C_theta P_theta + C_w P_w is then formed twice:

- on the MEASURED responses of identification.json's ``frequency_response``, from the
  command to the position and to the speed the law reads (the drive's reported speed where
  it was recorded, else the position's backward difference): they hold the drive, the bus's
  and the host's delay (the command of a sample reaches the drive at the next SYNC), the ZOH
  and whatever (3.5) leaves out (the current loop, a resonance); only the coherent band
  (coherence >= 0.9) is used;
- on the MODEL, (3.5) with a ZOH and the identified delay, from 0.1 Hz to Nyquist.

The margins of both are reported (``controllers.tuning.margins``, with a gain margin of 0 dB or
less where the loop is at or beyond the stability boundary, and each loop's verdict: stable,
marginal or unstable); a warning says when the crossover leaves the coherent band (the measured
margins are then not known), when there is no measured response, when the design is marginal
or unstable on either response, or when a margin is below what a drives engineer accepts
(45 deg, 6 dB). The design document is what ``[controller] design = "FILE"`` runs: ``law`` (the
``[controller] kind``), ``params`` (its parameters), and a_m, b_m, dt, input.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivers.errors import ConfigError
from drivers.files import read_json
from rig.config.model import FILE
from rig.identify.frequency import longest_run

__all__ = ["GM_MIN", "LAWS", "PM_MIN", "TuneRequest", "tune"]

#: the laws ``rig tune`` designs (``[controller] kind``)
LAWS = ("position-servo", "pi-speed", "cascade-position")
PM_MIN = 45.0  #: [deg] a phase margin below this is warned
GM_MIN = 6.0  #: [dB] a gain margin below this is warned
#: speed loop at least this many times the position loop's bandwidth in a cascade
CASCADE_RATIO = 4.0


@dataclass(frozen=True)
class TuneRequest:
    """What to design: ``law`` and its numbers (SI; bandwidths in Hz)."""

    law: str  #: the law to design (``rig tune``'s)
    lam: float | None = None  #: position-servo: (7.30)'s sliding eigenvalue [1/s]
    h: float = 16.0  #: position-servo: (7.30)'s integral gain [1/s]
    bandwidth: float | None = None  #: pi-speed: crossover [Hz]
    speed_bandwidth: float | None = None  #: cascade-position [Hz]
    position_bandwidth: float | None = None  #: cascade-position [Hz]
    u_max: float | None = None  #: the command's limit [V or N m]
    speed_max: float = 100.0  #: cascade-position: the position loop's output limit [rad/s]
    dt: float | None = None  #: [s] (default: the identification's)


def _identification(path: str | Path) -> tuple[dict[str, Any], Path]:
    p = Path(path)
    if p.is_dir():
        p = p / FILE
    doc = read_json(p, what="identification")
    if not isinstance(doc, dict):
        raise ConfigError(f"{p}: not a JSON object (rig identify's {FILE})")
    for key in ("a_m", "b_m", "dt"):
        v = doc.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ConfigError(f"{p}: {key} = {v!r}: expected a finite number (rig identify's {FILE})")
    return doc, p


def _complex(doc: dict[str, Any], mag: str, phase: str) -> np.ndarray:
    out: np.ndarray = 10.0 ** (np.asarray(doc[mag], dtype=float) / 20.0) * np.exp(
        1j * np.radians(np.asarray(doc[phase], dtype=float))
    )
    return out


def _design(req: TuneRequest, a: float, b: float, dt: float) -> tuple[dict[str, Any], Any]:
    """(the law's parameters, f -> (C_theta, C_w)) of ``req`` on (3.5) = (a, b) at ``dt``."""
    from controllers import tuning
    from controllers.design import design_dtsm

    if req.law == "position-servo":
        if req.lam is None or not req.lam < 0.0:
            raise ValueError(f"--lam {req.lam}: give the sliding eigenvalue lambda < 0 [1/s]")
        if not 0.0 <= req.h < 1.0 / dt:
            raise ValueError(f"--h {req.h:g}: (7.30d) needs 0 <= h < 1/T = {1.0 / dt:g} 1/s")
        design = design_dtsm(A=[[0.0, 1.0], [0.0, -a]], b=[0.0, -b], dt=dt, lam=req.lam)
        params: dict[str, Any] = {"a_m": a, "b_m": b, "lam": req.lam, "h": req.h}
        if req.u_max is not None:
            params["u0"] = req.u_max
        return params, lambda f: tuning.servo_response(design, req.h, f)
    if req.law == "pi-speed":
        if req.bandwidth is None:
            raise ValueError("--bandwidth: give the speed loop's crossover [Hz]")
        kp, ki = tuning.pi_from_bandwidth(a=a, b=b, bandwidth=2.0 * math.pi * req.bandwidth)
        params = {"kp": kp, "ki": ki}
        if req.u_max is not None:
            params.update(u_max=req.u_max, u_min=-req.u_max)
        return params, lambda f: (np.zeros(len(f)), tuning.pi_response(kp, ki, dt, f))
    if req.law == "cascade-position":
        if req.speed_bandwidth is None or req.position_bandwidth is None or req.u_max is None:
            raise ValueError("give --speed-bandwidth, --position-bandwidth [Hz] and --u-max")
        speed, position = tuning.cascade_from_bandwidths(
            a=a,
            b=b,
            dt=dt,
            speed_bandwidth=2.0 * math.pi * req.speed_bandwidth,
            position_bandwidth=2.0 * math.pi * req.position_bandwidth,
            u_max=req.u_max,
            speed_max=req.speed_max,
        )
        params = {"k_t": 1.0, "position_every": 1}
        for name, loop in (("speed", speed), ("position", position)):
            for key in ("c_s", "k_s", "k_r1", "k_r2", "k_int", "u0", "beta", "alpha"):
                value = getattr(loop, key)
                params[f"{name}_{key}"] = list(value) if isinstance(value, tuple) else value
        return params, lambda f: tuning.cascade_response(speed, position, 1.0, f)
    raise ValueError(f"law {req.law!r}: one of {', '.join(LAWS)}")


def _model_loop(response: Any, a: float, b: float, dt: float, delay: int) -> tuple[np.ndarray, np.ndarray]:
    """(f, L) on the model: (3.5) with a ZOH and ``delay``, the speed as a drive samples it."""
    from rig.identify.frequency import model_speed_response, model_velocity_response, speed_to_position

    f = np.geomspace(0.1, 0.4999 / dt, 3000)
    p_theta = model_speed_response(a, b, dt, delay, f) * speed_to_position(f, dt)
    c_theta, c_w = response(f)
    return f, c_theta * p_theta + c_w * model_velocity_response(a, b, dt, delay, f)


def _measured_loop(
    response: Any, fr: dict[str, Any], position: bool
) -> tuple[np.ndarray, np.ndarray, str, tuple[float, float] | None]:
    """(f, L, the speed used, the coherent band) on the measured responses, within the band
    where every response the law uses (the position's only if ``position``) is coherent."""
    f = np.asarray(fr["frequency"], dtype=float)
    p_theta = _complex(fr, "position_magnitude_db", "position_phase_deg")
    coherence = np.asarray(fr["coherence"], dtype=float)
    if "velocity_magnitude_db" in fr:
        p_w, speed = _complex(fr, "velocity_magnitude_db", "velocity_phase_deg"), "the drive's reported speed"
        reported = np.asarray(fr["velocity_coherence"], dtype=float)
        coherence = np.minimum(coherence, reported) if position else reported
    else:
        p_w, speed = _complex(fr, "magnitude_db", "phase_deg"), "the position's backward difference"
    band = longest_run(f, coherence >= fr["coherence_min"])
    if band is None:
        return f[:0], p_w[:0], speed, None
    keep = (f >= band[0]) & (f <= band[1])
    c_theta, c_w = response(f[keep])
    return f[keep], c_theta * p_theta[keep] + c_w * p_w[keep], speed, band


def _margin_warnings(measured: Any, model: Any) -> list[str]:
    """The warnings of each loop's margins: at or beyond the boundary, or below PM_MIN, GM_MIN."""
    out: list[str] = []
    for name, m in (("measured", measured), ("model", model)):
        if m is None:
            continue
        if m.verdict in ("marginal", "unstable"):
            out.append(_boundary(name, m))
            continue
        if m.phase_margin_deg is not None and m.phase_margin_deg < PM_MIN:
            out.append(f"the {name} phase margin is {m.phase_margin_deg:.1f} deg (< {PM_MIN:g} deg)")
        if m.gain_margin_db is not None and m.gain_margin_db < GM_MIN:
            out.append(f"the {name} gain margin is {m.gain_margin_db:.1f} dB (< {GM_MIN:g} dB)")
    return out


def _boundary(name: str, m: Any) -> str:
    """The warning of a loop at or beyond the stability boundary (``Margins.verdict``)."""
    where = "at" if m.verdict == "marginal" else "beyond"
    gm = (
        "no phase crossover"
        if m.gain_margin_db is None
        else f"gain margin {m.gain_margin_db:.2f} dB at {m.phase_crossover_hz:.6g} Hz"
    )
    pm = (
        "no gain crossover (|L| > 1 throughout)"
        if m.phase_margin_deg is None
        else f"phase margin {m.phase_margin_deg:.3g} deg at {m.crossover_hz:.6g} Hz"
    )
    return (
        f"the design is {m.verdict} on the {name} response ({where} the stability boundary): {gm}, {pm}; "
        "the closed loop oscillates near the phase crossover or diverges"
    )


def _cascade_warnings(req: TuneRequest) -> list[str]:
    """A cascade whose speed loop is not ``CASCADE_RATIO`` times faster than its position loop."""
    ws, wp = req.speed_bandwidth, req.position_bandwidth
    if req.law == "cascade-position" and ws is not None and wp is not None and ws < CASCADE_RATIO * wp:
        return [
            f"the speed loop ({ws:g} Hz) is less than {CASCADE_RATIO:g} times the position loop ({wp:g} "
            "Hz): the position loop sees more than the first-order speed loop it was designed on"
        ]
    return []


def _measured(
    req: TuneRequest, response: Any, fr: Any, *, dt: float, dt_ident: float, model: Any
) -> tuple[Any, tuple[float, float] | None, str | None, list[str]]:
    """The loop's margins on the measured frequency response ``fr`` (None where the identification
    has none, or measured it at a period other than ``dt`` [s]), its coherent band [Hz], the speed
    it used, and the warnings (why only the model's, or a crossover outside the band)."""
    from controllers.tuning import margins

    if not isinstance(fr, dict) or fr.get("coherent_band") is None:
        return (
            None,
            None,
            None,
            [
                "margins on the model only: the identification has no coherent frequency response "
                "(rig identify --excitation multisine measures one)"
            ],
        )
    if abs(dt - dt_ident) > 1e-9 * dt:
        return (
            None,
            None,
            None,
            [
                f"margins on the model only: designed for T = {dt:g} s, the response was measured at "
                f"T = {dt_ident:g} s"
            ],
        )
    f, loop, speed, band = _measured_loop(response, fr, req.law != "pi-speed")
    measured = margins(f, loop)
    wc = model.crossover_hz if measured.crossover_hz is None else measured.crossover_hz
    if band is None or wc is None or not band[0] <= wc <= band[1]:
        band = band or (math.nan, math.nan)
        where = "none" if wc is None else f"{wc:.3g} Hz"
        return (
            measured,
            band,
            speed,
            [
                f"the loop's crossover ({where}) leaves the coherent band {band[0]:g} .. {band[1]:g} Hz: "
                "its measured margins are not known; lower the bandwidth or measure further "
                "(--f-max, a larger --amplitude, a longer --duration)"
            ],
        )
    return measured, band, speed, []


def tune(source: str | Path, req: TuneRequest) -> dict[str, Any]:
    """The design document of ``req`` on the identification ``source`` (identification.json
    or its run directory): law, params, a_m, b_m, dt, input, margins (measured, model),
    coherent_band, speed_feedback, warnings. ValueError for a request that cannot be designed.

    Parameters
    ----------
    source : str | Path
        identification.json or its run directory.
    req : TuneRequest
        What to design.

    Returns
    -------
    dict[str, Any]
        The design document.
    """
    from controllers.tuning import margins

    doc, path = _identification(source)
    a, b, dt_ident = float(doc["a_m"]), float(doc["b_m"]), float(doc["dt"])
    dt = dt_ident if req.dt is None else req.dt
    params, response = _design(req, a, b, dt)
    delay = int(doc.get("delay_samples", 1))
    f_model, l_model = _model_loop(response, a, b, dt, delay)
    model = margins(f_model, l_model)
    fr = doc.get("frequency_response")
    measured, band, speed, said = _measured(req, response, fr, dt=dt, dt_ident=dt_ident, model=model)
    warnings = _cascade_warnings(req) + said + _margin_warnings(measured, model)
    return {
        "law": req.law,
        "params": params,
        "a_m": a,
        "b_m": b,
        "dt": dt,
        "input": doc.get("input", "voltage"),
        **({"lam": req.lam} if req.law == "position-servo" else {}),
        "identification": str(path),
        "margins": {
            "measured": None if measured is None else measured.as_dict(),
            "model": model.as_dict(),
        },
        "coherent_band": None if band is None or math.isnan(band[0]) else list(band),
        "delay": delay * float(doc["dt"]),
        "speed_feedback": speed,
        "warnings": warnings,
    }
