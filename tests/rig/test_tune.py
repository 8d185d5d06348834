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
    encoder's coherent band, and with the synchronous RPDO's period of delay it has no phase
    margin left: both said."""
    doc, err = _tune(capsys, "position-servo", "--lam", "-15", "--from-identify", str(identified))
    assert "leaves the coherent band 10 .. " in err and "the model phase margin is" in err, err
    assert doc["margins"]["measured"]["phase_margin_deg"] is None
    assert (
        doc["margins"]["model"]["crossover_hz"] > 300.0 and doc["margins"]["model"]["phase_margin_deg"] < 10
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
