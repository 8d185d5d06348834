"""rig identify in CST on the zoo's twins: the frequency response measured under a weak speed loop
(the excitation added to its torque command, G = G_ry / G_ru), against the twin's plant computed
here with scipy from its motor's constants; the loop's law, its refusals."""

from __future__ import annotations

import json
import math
import pathlib
import warnings

import numpy as np
import pytest
import scipy.signal

from drivers.base import Feedback
from drivers.errors import SafetyStop
from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.device_profile import device_profile
from plant_emulator.presets import preset_params
from rig.cli import main
from rig.identify.frequency import COHERENCE_MIN
from rig.laws.excited import ExcitedSpeedLaw, ExcitedSpeedParams

T = 0.4e-3  #: the twins' period [s]


def _motor(device: str) -> DCMotorParams:
    p = preset_params(device_profile(device).physics, device_profile(device).params)
    return DCMotorParams.from_am_bm(a_m=p.a_m, b_m=p.b_m, r_r=p.r_r, tau_e=p.tau_e, b=p.friction)


def _speed_response(ad: np.ndarray, bd: np.ndarray, c: list[list[float]], f: np.ndarray) -> np.ndarray:
    """The position's sampled system (ad, bd, c) by scipy.signal.dlti and dfreqresp at ``f`` [Hz],
    then a period's delay and the backward difference (1 - z^-1) / T. (dfreqresp goes through a
    transfer function whose numerator starts with the structural zero of a strictly proper
    system: scipy warns BadCoefficients about it, harmless here.)"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scipy.signal.BadCoefficients)
        w, theta = scipy.signal.dfreqresp(scipy.signal.dlti(ad, bd, c, [[0.0]], dt=T), w=2 * np.pi * f * T)
    z = np.exp(1j * w)
    out: np.ndarray = theta.ravel() * (1 - 1 / z) / T / z
    return out


def _twin_plant(m: DCMotorParams, f: np.ndarray) -> np.ndarray:
    """The twin's response from the torque command to the speed by backward difference, from its
    motor's constants: (3.4) (J, B, k, R, L; Coulomb friction a constant at one sign of speed)
    behind the drive's deadbeat current loop (at each of four substeps a period the voltage
    k_e w + R (i_ref - d i) / (1 - d), d = e^(-h R/L), linear in the state), the torque held
    over the period, a period's delay (the synchronous RPDO); by scipy.signal.cont2discrete,
    dlti and dfreqresp."""
    hs = T / 4
    a = np.array([[0, 1, 0], [0, -m.b / m.j, m.k_t / m.j], [0, -m.k_e / m.l_r, -m.r_r / m.l_r]])
    b = np.array([[0.0], [0.0], [1 / m.l_r]])
    ad, bd, *_ = scipy.signal.cont2discrete((a, b, np.eye(3), np.zeros((3, 1))), hs)
    d = math.exp(-hs * m.r_r / m.l_r)
    f_sub = ad + bd @ np.array([[0.0, m.k_e, -m.r_r * d / (1 - d)]])
    g_sub = bd * m.r_r / ((1 - d) * m.k_t)
    f_period = np.linalg.matrix_power(f_sub, 4)
    g_period = sum(np.linalg.matrix_power(f_sub, i) for i in range(4)) @ g_sub
    return _speed_response(f_period, g_period, [[1.0, 0.0, 0.0]], f)


def _rigid_body(m: DCMotorParams, f: np.ndarray) -> np.ndarray:
    """J dw/dt = -B w + T only, ZOH, a period's delay (scipy.signal.cont2discrete, dfreqresp)."""
    a, b = np.array([[0, 1], [0, -m.b / m.j]]), np.array([[0.0], [1 / m.j]])
    ad, bd, *_ = scipy.signal.cont2discrete((a, b, [[1.0, 0.0]], [[0.0]]), T)
    return _speed_response(ad, bd, [[1.0, 0.0]], f)


def _ratio_db_deg(fr: dict, model: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    measured = 10 ** (np.asarray(fr["magnitude_db"]) / 20) * np.exp(1j * np.radians(fr["phase_deg"]))
    ratio = measured[mask] / model[mask]
    return float(np.abs(20 * np.log10(np.abs(ratio))).max()), float(np.abs(np.degrees(np.angle(ratio))).max())


@pytest.mark.parametrize(
    "device,amplitude,periods",
    [("epos4", "0.1", 21), ("kollmorgen-s300", "0.05", 16)],  # 4096 counts; the S300's resolver, finer
)
def test_the_closed_loop_response_in_cst_is_the_twin_s_plant(
    device: str, amplitude: str, periods: int, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A near integrator (B/J = 0.066 1/s) in CST under a weak speed loop designed on a J 30 % off:
    where the coherence (r to u and r to y) is >= 0.9, the measured response is the twin's
    plant within 1 dB and 5 deg, and (3.5)'s rigid body (J, B, one period's delay) below 100 Hz,
    where the current loop's lag is under a degree; J from the fitted b_m within 2 %."""
    m = _motor(device)
    prior = {"a_m": 0.0, "b_m": 1.0 / (1.3 * m.j), "dt": T, "input": "torque"}
    (tmp_path / "identification.json").write_text(json.dumps(prior))
    argv = [
        "identify",
        "--emulate",
        device,
        "--input",
        "torque",
        "--excitation",
        "multisine",
        "--f-min",
        "10",
    ]
    argv += [
        "--duration",
        str(periods / 10),
        "--amplitude",
        amplitude,
        "--loop-model",
        str(tmp_path),
        "--json",
    ]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    fr = doc["frequency_response"]
    assert fr["method"] == "indirect" and doc["warnings"] == [], doc["warnings"]
    f = np.asarray(fr["frequency"])
    coherent = np.asarray(fr["coherence"]) >= COHERENCE_MIN
    assert fr["coherent_band"][0] == 10.0 and fr["coherent_band"][1] >= 150.0
    assert np.asarray(fr["input_coherence"])[coherent].min() >= COHERENCE_MIN
    db, deg = _ratio_db_deg(fr, _twin_plant(m, f), coherent)
    assert db < 1.0 and deg < 5.0, (db, deg)
    db, deg = _ratio_db_deg(fr, _rigid_body(m, f), coherent & (f <= 100.0))
    assert db < 1.0 and deg < 5.0, (db, deg)
    assert 1.0 / doc["b_m"] == pytest.approx(m.j, rel=0.02) and doc["delay_samples"] == 1
    config = json.loads((pathlib.Path(doc["run_dir"]) / "config.json").read_text())["controller"]
    assert config["kind"] == "excited-speed" and config["params"]["speed"] > 0.0


def test_in_cst_a_frequency_response_needs_the_loop_s_model(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = [
        "identify",
        "--emulate",
        "epos4",
        "--input",
        "torque",
        "--excitation",
        "multisine",
        "--f-min",
        "10",
    ]
    assert main(base) == 2
    assert "give --loop-model RUN_DIR of a rig identify --input torque" in capsys.readouterr().err
    (tmp_path / "identification.json").write_text(json.dumps({"a_m": 16.0, "b_m": 680.0, "dt": T}))
    assert main([*base, "--loop-model", str(tmp_path)]) == 2
    assert "b_m = 680 per unit of voltage: expected b_m > 0 with --input torque" in capsys.readouterr().err
    (tmp_path / "identification.json").write_text(
        json.dumps({"a_m": 0.0, "b_m": 2.9e4, "dt": T, "input": "torque"})
    )
    assert main([*base, "--loop-model", str(tmp_path), "--amplitude", "0.05", "--speed", "1"]) == 2
    err = capsys.readouterr().err
    assert "the closed-loop experiment's speed 1 rad/s: the excitation swings the speed by" in err, err
    assert main([*base, "--loop-model", str(tmp_path), "--loop-bandwidth", "20"]) == 2
    assert "--loop-bandwidth: 20 Hz: expected 0 < it < --f-min (10 Hz)" in capsys.readouterr().err
    assert main([*base, "--loop-model", str(tmp_path), "--amplitude", "-0.05"]) == 2
    assert "need --amplitude > 0, got -0.05" in capsys.readouterr().err


def _feedback(velocity: float) -> list[Feedback]:
    return [Feedback(position=0.0, velocity=velocity)]


def test_the_loop_adds_the_excitation_and_stops_on_the_other_sign() -> None:
    """u = k_p e + k_i T sum(e) + r; the excitation is recorded; a reversed speed after the first
    tenth of the run is a safe stop naming what to do."""
    p = ExcitedSpeedParams(u=(0.01, -0.01), cycles=20, speed=10.0, kp=0.002, ki=0.04)
    law = ExcitedSpeedLaw(p, period=T, reference=lambda t: (0.0, 0.0))
    first = law.step(0.0, _feedback(4.0))
    assert first.commands[0] == pytest.approx(0.002 * 6.0 + 0.01) and first.internals == (
        0.01,
        0.04 * T * 6.0,
    )
    second = law.step(T, _feedback(4.0))
    assert second.commands[0] == pytest.approx(0.002 * 6.0 + 0.04 * T * 6.0 - 0.01)
    law.step(2 * T, _feedback(-1.0))  # within the first tenth: the start
    with pytest.raises(SafetyStop, match=r"changed sign: raise the loop's speed \(10 rad/s, --speed\)"):
        law.step(3 * T, _feedback(-1.0))


def test_in_a_strong_loop_h1_is_biased_and_the_indirect_estimate_is_not() -> None:
    """(3.5) of a twin (a = 0.066 1/s, b = 29,000 1/(kg m^2), a period's delay) under a PI speed
    loop crossing over at 40 Hz on the backward difference of a 4096-count encoder, the
    excitation added to its torque: the encoder's noise comes back into u through the loop, and
    H1 = G_uy / G_uu is pulled towards -1/C (3.3 dB, 6.5 deg off here); G_ry / G_ru is within
    1 dB and 5 deg over the same coherent bins."""
    from rig.identify.frequency import frequency_response, model_speed_response, periodic_excitation

    a, b, q = 0.066, 29_000.0, 2 * math.pi / 4096
    r = periodic_excitation("multisine", u0=0.0, amplitude=0.02, dt=T, duration=4.1, f_min=10.0)
    alpha = math.exp(-a * T)
    g = (1 - alpha) / a
    h = (T - g) / a
    w_c = 2 * math.pi * 40
    kp = w_c / b
    ki = kp * w_c / 4
    theta = w = integral = held = last = 0.0
    u, measured = np.empty(len(r)), np.empty(len(r))
    for n in range(len(r)):
        measured[n] = math.floor(theta / q) * q
        e = 20.0 - (measured[n] - last) / T
        last = measured[n]
        u[n] = kp * e + integral + r[n]
        integral += ki * T * e
        theta, w = theta + g * w + h * b * held, alpha * w + g * b * held  # u of the last period
        held = u[n]
    indirect = frequency_response(u, measured, T, f_min=10.0, settle=0.3, r=r)
    h1 = frequency_response(u, measured, T, f_min=10.0, settle=0.3)
    mask = indirect.coherent
    assert indirect.method == "indirect" and np.count_nonzero(mask) >= 8
    model = model_speed_response(a, b, T, 1, indirect.f)[mask]
    for estimate, within in ((indirect, True), (h1, False)):
        ratio = estimate.speed[mask] / model
        worst = np.abs(20 * np.log10(np.abs(ratio))).max(), np.abs(np.degrees(np.angle(ratio))).max()
        assert bool(worst[0] < 1.0 and worst[1] < 5.0) == within, (estimate.method, worst)
    assert np.abs(20 * np.log10(np.abs(h1.speed[mask] / model))).max() > 2.0
