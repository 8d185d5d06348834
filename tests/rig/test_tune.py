"""rig tune: the papers' laws designed from rig identify's result, their margins on the measured
frequency response and on the model, the warnings, and the design run by [controller] design."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from drivers.errors import ConfigError
from rig.cli import main
from rig.config import load_config


def _tune(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[dict, str]:
    assert main(["tune", *argv, "--json"]) == 0
    out = capsys.readouterr()
    return json.loads(out.out), out.err


TAU_E = 1e-4  #: [s] the dc-servo preset's armature time constant, which (3.5) leaves out


@pytest.mark.parametrize(
    "argv",
    [
        ("pi-speed", "--bandwidth", "20", "--u-max", "48"),
        ("pi-speed", "--bandwidth", "150"),
        ("cascade-position", "--speed-bandwidth", "40", "--position-bandwidth", "5", "--u-max", "48"),
    ],
)
def test_the_measured_margins_hold_what_the_model_leaves_out(
    identified: pathlib.Path, capsys: pytest.CaptureFixture[str], argv: tuple[str, ...]
) -> None:
    """At the crossover f_c the measured phase margin is the model's less the armature pole's
    lag atan(2 pi f_c tau_e) (0.9 deg at 24 Hz, 5.4 deg at 150 Hz), which only the
    measurement sees."""
    doc, err = _tune(capsys, *argv, "--from-identify", str(identified))
    measured, model = doc["margins"]["measured"], doc["margins"]["model"]
    assert doc["law"] == argv[0] and doc["dt"] == pytest.approx(0.4e-3) and doc["input"] == "voltage"
    fc = measured["crossover_hz"]
    assert fc == pytest.approx(model["crossover_hz"], rel=0.05)
    lag = np.degrees(np.arctan(2 * np.pi * fc * TAU_E))
    assert measured["phase_margin_deg"] == pytest.approx(model["phase_margin_deg"] - lag, abs=1.5)
    assert measured["phase_margin_deg"] > 45.0 and "warning" not in err, err
    assert measured["delay_margin"] == pytest.approx(
        np.radians(measured["phase_margin_deg"]) / (2 * np.pi * fc)
    )
    assert doc["speed_feedback"] == "the drive's reported speed" and doc["delay"] == pytest.approx(0.4e-3)


@pytest.mark.parametrize("bandwidth", ["20", "150"])
def test_the_measured_margins_are_python_control_s(
    identified: pathlib.Path, capsys: pytest.CaptureFixture[str], bandwidth: str
) -> None:
    """The PI's loop formed here from identification.json's measured response to the drive's
    reported speed (its coherent bins) and the law's C_w = k_p + k_i T / (z - 1) (controllers.pi:
    u_k = k_p e_k + I_k, I_k+1 = I_k + k_i T e_k): python-control's stability_margins on it as
    frequency response data give the phase margin and crossover rig tune reports."""
    import control

    doc, _ = _tune(capsys, "pi-speed", "--bandwidth", bandwidth, "--from-identify", str(identified))
    fr = json.loads((identified / "identification.json").read_text())["frequency_response"]
    f = np.asarray(fr["frequency"])
    keep = np.asarray(fr["velocity_coherence"]) >= fr["coherence_min"]
    plant = 10 ** (np.asarray(fr["velocity_magnitude_db"]) / 20) * np.exp(
        1j * np.radians(fr["velocity_phase_deg"])
    )
    z = np.exp(2j * np.pi * f * doc["dt"])
    loop = (doc["params"]["kp"] + doc["params"]["ki"] * doc["dt"] / (z - 1)) * plant
    frd = control.frd(loop[keep], 2 * np.pi * f[keep])
    _, pm, _, _, wc, _ = control.stability_margins(frd)
    measured = doc["margins"]["measured"]
    assert measured["phase_margin_deg"] == pytest.approx(pm, abs=1.0)
    assert measured["crossover_hz"] == pytest.approx(wc / (2 * np.pi), rel=0.02)


def _overshoot_of(phase_margin: float) -> float:
    """The step overshoot of the standard second-order loop w_n^2 / (s (s + 2 zeta w_n)) with that
    phase margin [deg]: PM = atan(2 zeta / sqrt(sqrt(1 + 4 zeta^4) - 2 zeta^2)) solved for zeta,
    overshoot exp(-pi zeta / sqrt(1 - zeta^2)) (K. Ogata, Modern Control Engineering)."""
    import scipy.optimize

    def pm(zeta: float) -> float:
        return float(np.degrees(np.arctan(2 * zeta / np.sqrt(np.sqrt(1 + 4 * zeta**4) - 2 * zeta**2))))

    zeta = scipy.optimize.brentq(lambda x: pm(x) - phase_margin, 0.05, 0.99)
    return float(np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2)))


def test_a_pi_s_model_margin_is_what_its_delay_leaves(
    identified: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """k_p b / s with the loop's delay: at 150 Hz the RPDO's period, half a period of the ZOH and
    the speed sampled at the SYNC take 150 * 360 * 1.5 * 0.4 ms = 32 deg of the 90."""
    doc, _ = _tune(capsys, "pi-speed", "--bandwidth", "150", "--from-identify", str(identified))
    assert doc["margins"]["model"]["phase_margin_deg"] == pytest.approx(90.0 - 32.4, abs=1.5)


def test_a_bandwidth_beyond_the_coherent_band_is_warned(
    identified: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """(7.30)'s linear mode reaches in one period (g/T): its crossover is near 420 Hz, above the
    encoder's coherent band, and with the synchronous RPDO's period of delay it has no margin
    left (0 dB of gain margin at 415 Hz, was none): both said."""
    doc, err = _tune(capsys, "position-servo", "--lam", "-15", "--from-identify", str(identified))
    assert "leaves the coherent band 10 .. " in err and "the design is marginal on the model" in err, err
    assert doc["margins"]["measured"]["phase_margin_deg"] is None
    model = doc["margins"]["model"]
    assert model["crossover_hz"] > 300.0 and model["phase_margin_deg"] < 10
    assert (
        model["gain_margin_db"] == pytest.approx(0.0, abs=0.1) and 400.0 < model["phase_crossover_hz"] < 420
    )
    assert (
        main(["tune", "position-servo", "--lam", "-15", "--from-identify", str(identified), "--strict"]) == 5
    )
    capsys.readouterr()


def test_without_a_frequency_response_the_margins_are_the_model_s(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "identification.json").write_text(json.dumps({"a_m": 16.0, "b_m": 680.0, "dt": 4e-4}))
    doc, err = _tune(capsys, "pi-speed", "--bandwidth", "20", "--from-identify", str(tmp_path))
    assert doc["margins"]["measured"] is None and doc["margins"]["model"]["phase_margin_deg"] > 80
    assert "margins on the model only" in err


def test_bad_requests_are_usage_errors(identified: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = ["tune", "--from-identify", str(identified)]
    assert main([*base[:1], "pi-speed", *base[1:]]) == 2
    assert "--bandwidth: give the speed loop's crossover" in capsys.readouterr().err
    assert main([*base[:1], "cascade-position", *base[1:], "--speed-bandwidth", "40"]) == 2
    assert "give --speed-bandwidth, --position-bandwidth" in capsys.readouterr().err
    assert main([*base[:1], "pi-speed", *base[1:], "--bandwidth", "-3"]) == 2
    assert "--bandwidth: must be > 0, got -3" in capsys.readouterr().err
    assert main(["tune", "pi-speed", "--bandwidth", "20", "--from-identify", "/nonexistent"]) == 2
    assert "/nonexistent" in capsys.readouterr().err


SPEED = """
[run]
duration = 0.6
output = "{out}"
name = "tuned"

[emulator]
preset = "dc-servo"

[[axis]]
name = "motor"
kind = "cia402"
node_id = 1
mode = "voltage"
sync_rpdo = true

[axis.limits]
command = 48.0
speed = 300.0
current = 60.0

[controller]
kind = "{kind}"
reads = ["motor"]
commands = ["motor"]
design = "design.json"

[reference]
{reference}
"""


def _run(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], kind: str, reference: str, design: dict
) -> dict:
    (tmp_path / "design.json").write_text(json.dumps(design))
    config = tmp_path / "rig.toml"
    config.write_text(SPEED.format(out=tmp_path, kind=kind, reference=reference))
    assert main(["run", "--config", str(config), "--emulate", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["safe_stop_reason"] is None
    return summary


def _overshoot(run_dir: str, target: float) -> float:
    data = np.genfromtxt(pathlib.Path(run_dir) / "samples.csv", delimiter=",", names=True)
    return float(np.max(data["motorvelocity"]) / target - 1.0)


def test_the_designs_run_and_the_step_overshoot_follows_the_phase_margin(
    identified: pathlib.Path, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The PI at 20 Hz (measured margin near 85 deg) steps to 5 rad/s without overshoot; at
    150 Hz (near 52 deg) it overshoots, as a loop of that margin does; the cascade follows."""
    step = 'kind = "step"\nvalue = 5.0\nstart = 0.1'  # small: the loop stays linear (6.9 V at 150 Hz)
    gentle, _ = _tune(
        capsys, "pi-speed", "--bandwidth", "20", "--u-max", "48", "--from-identify", str(identified)
    )
    fast, _ = _tune(
        capsys, "pi-speed", "--bandwidth", "150", "--u-max", "48", "--from-identify", str(identified)
    )
    assert _overshoot(_run(tmp_path, capsys, "pi-speed", step, gentle)["run_dir"], 5.0) < 0.01
    predicted = _overshoot_of(fast["margins"]["measured"]["phase_margin_deg"])  # 16 % at 52 deg
    assert _overshoot(_run(tmp_path, capsys, "pi-speed", step, fast)["run_dir"], 5.0) == pytest.approx(
        predicted, abs=0.04
    )
    cascade, _ = _tune(
        capsys,
        "cascade-position",
        "--speed-bandwidth",
        "40",
        "--position-bandwidth",
        "5",
        "--u-max",
        "48",
        "--from-identify",
        str(identified),
    )
    move = 'kind = "smooth-move"\ndistance = 2.0\nduration = 0.3'
    summary = _run(tmp_path, capsys, "cascade-position", move, cascade)
    assert summary["rms_error"] < 0.05, summary


def test_a_design_is_for_its_law(
    identified: pathlib.Path, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    design, _ = _tune(capsys, "pi-speed", "--bandwidth", "20", "--from-identify", str(identified))
    (tmp_path / "design.json").write_text(json.dumps(design))
    config = tmp_path / "rig.toml"
    config.write_text(SPEED.format(out=tmp_path, kind="cascade-position", reference='kind = "constant"'))
    with pytest.raises(ConfigError, match=r"designed for kind = 'pi-speed', not 'cascade-position'"):
        load_config(config)
    config.write_text(SPEED.format(out=tmp_path, kind="pi-speed", reference='kind = "constant"') + "\n")
    text = config.read_text().replace('design = "design.json"', 'design = "design.json"\nkp = 1.0')
    config.write_text(text)
    with pytest.raises(ConfigError, match=r"kp also given in \[controller\]"):
        load_config(config)


def _servo_loop_by_python_control(a: float, b: float, dt: float, lam: float, h: float) -> tuple:
    """(C_theta, C_w, P_theta, P_w) of (7.30)'s linear mode on (3.5) with a ZOH and a period's
    delay, as python-control's discrete transfer functions (sample_system, not this package's
    responses): the position b/(s (s + a)) and the speed b/(s + a) sampled at the same instants."""
    import control

    from controllers.design import design_dtsm

    d = design_dtsm(A=[[0.0, 1.0], [0.0, -a]], b=[0.0, -b], dt=dt, lam=lam)
    (c1, c2), (k1, k2) = d.c_delta, d.c_delta_A_delta
    z = control.tf([1.0, 0.0], [1.0], dt)
    gain = 1.0 / dt + h * z / (z - 1)
    delay = control.tf([1.0], [1.0, 0.0], dt)
    p_theta = control.sample_system(control.tf([b], [1.0, a, 0.0]), dt, "zoh") * delay
    p_w = control.sample_system(control.tf([b], [1.0, a]), dt, "zoh") * delay
    return -(k1 + gain * c1), -(k2 + gain * c2), p_theta, p_w


def _measured(tmp_path: pathlib.Path, a: float, b: float, plant_b: float) -> pathlib.Path:
    """identification.json of (a, b) at 0.4 ms with a period's delay, and a frequency response,
    coherent up to Nyquist, of the plant (a, ``plant_b``) built by python-control."""
    import control

    dt = 4e-4
    _, _, p_theta, p_w = _servo_loop_by_python_control(a, plant_b, dt, -15.0, 16.0)
    f = np.geomspace(10.0, 0.499 / dt, 1500)
    th, w = (control.frequency_response(p, 2 * np.pi * f) for p in (p_theta, p_w))
    resp = {
        "frequency": f.tolist(),
        "coherence": [1.0] * len(f),
        "velocity_coherence": [1.0] * len(f),
        "coherence_min": 0.9,
        "coherent_band": [float(f[0]), float(f[-1])],
    }
    for name, r in (("position", th), ("velocity", w)):
        resp[f"{name}_magnitude_db"] = (20 * np.log10(r.magnitude)).tolist()
        resp[f"{name}_phase_deg"] = np.degrees(np.unwrap(r.phase)).tolist()
    doc = {"a_m": a, "b_m": b, "dt": dt, "delay_samples": 1, "frequency_response": resp}
    (tmp_path / "identification.json").write_text(json.dumps(doc))
    return tmp_path


@pytest.mark.parametrize("plant_b,verdict", [(681.4, "marginal"), (2 * 681.4, "unstable")])
def test_a_loop_at_or_beyond_the_boundary_has_its_gain_margin(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], plant_b: float, verdict: str
) -> None:
    """(7.30) at lambda = -15 on (3.5) with a period's delay reaches in one period: its loop is
    at the stability boundary (phase margin -0.6 deg at 418 Hz). The gain margin is there, 0 dB
    or below with its frequency (was None), the one python-control's stability_margins finds on
    the loop it builds itself; the measured response of a plant of twice the b_m puts the design
    beyond the boundary (-6 dB) while the model leaves it marginal: both said."""
    import control

    a, b, dt = 16.02, 681.4, 4e-4
    doc, err = _tune(
        capsys, "position-servo", "--lam", "-15", "--from-identify", str(_measured(tmp_path, a, b, plant_b))
    )
    for name, plant in (("model", b), ("measured", plant_b)):
        c_theta, c_w, _, _ = _servo_loop_by_python_control(a, b, dt, -15.0, 16.0)  # designed on b
        _, _, p_theta, p_w = _servo_loop_by_python_control(a, plant, dt, -15.0, 16.0)
        gm, pm, _, wg, wc, _ = control.stability_margins(c_theta * p_theta + c_w * p_w)
        m = doc["margins"][name]
        assert m["gain_margin_db"] == pytest.approx(20 * np.log10(gm), abs=0.01), (name, m)
        assert m["gain_margin_db"] <= 0.0 and m["verdict"] == ("marginal" if name == "model" else verdict)
        assert m["phase_crossover_hz"] == pytest.approx(wg / (2 * np.pi), rel=1e-3)
        if m["crossover_hz"] is not None:  # twice the b_m: |L| > 1 up to Nyquist, no gain crossover
            assert m["phase_margin_deg"] == pytest.approx(pm, abs=0.05)
            assert m["crossover_hz"] == pytest.approx(wc / (2 * np.pi), rel=1e-3)
        assert f"the design is {m['verdict']} on the {name} response" in err, err
    assert main(["tune", "position-servo", "--lam", "-15", "--from-identify", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "margins on the measured plant (coherent band 10 .. 1247.5 Hz): phase" in out
    assert f"dB at {doc['margins']['measured']['phase_crossover_hz']:.4g} Hz" in out and verdict in out
