"""rig identify: recovery of known models, honest intervals, clear errors, offline mode, contracts."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from rig.cli import main
from rig.identify import IdentificationError, estimate, excitation, virtual_experiment


@pytest.mark.parametrize("a_m,b_m", [(16.0, 680.0), (23.5, 412.0), (8.0, 150.0)])
def test_recovers_the_emulated_motor_over_the_bus(
    a_m: float, b_m: float, capsys: pytest.CaptureFixture[str]
) -> None:
    """The experiment runs through the CiA 402 driver on the emulated dc-servo ((3.4), sync RPDO delay)."""
    u0 = 3.0 if b_m / a_m > 20 else 8.0
    args = ["identify", "--emulate", "dc-servo", "--param", f"plant.a_m={a_m}", "--param", f"plant.b_m={b_m}"]
    assert main([*args, "--duration", "2", "--u0", str(u0), "--amplitude", str(u0 * 0.6), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert {"a_m", "b_m", "a_m_stderr", "b_m_stderr", "fit_percent", "delay_samples", "offset"} <= set(r)
    assert r["a_m"] == pytest.approx(a_m, rel=5e-3)
    assert r["b_m"] == pytest.approx(b_m, rel=5e-3)
    assert r["delay_samples"] == 1 and r["fit_percent"] > 90.0


def test_interval_contains_the_truth_and_estimate_is_unbiased_under_quantisation() -> None:
    covered, errors = 0, []
    for seed in range(10):
        u, theta = virtual_experiment(16.0, 680.0, seed=seed, delay=2, coulomb=0.1)
        r = estimate(u, theta, 1e-3)
        assert r.delay_samples == 2
        covered += r.a_m_ci95[0] <= 16.0 <= r.a_m_ci95[1] and r.b_m_ci95[0] <= 680.0 <= r.b_m_ci95[1]
        errors.append(r.a_m / 16.0 - 1.0)
        assert r.offset == pytest.approx(-0.1 * 680.0, rel=0.01)  # Coulomb friction as the offset
    assert covered >= 7
    assert abs(np.mean(errors)) < 1e-3


def test_differenced_velocity_least_squares_is_biased_and_not_used() -> None:
    """The naive estimator (LS on differenced quantised velocity) is off by percent (3.8 % here,
    4096 counts at 1 kHz); ours is within 0.1 %."""
    u, theta = virtual_experiment(16.0, 680.0, seed=3, noise_counts=0.0, coulomb=0.0, delay=0)
    w = np.diff(theta) / 1e-3
    phi = np.column_stack([-w[:-1], u[1:-1], np.ones(len(w) - 1)])
    (a_naive, *_), *_ = np.linalg.lstsq(phi, (w[1:] - w[:-1]) / 1e-3, rcond=None)
    assert abs(a_naive / 16.0 - 1.0) > 0.02
    assert abs(estimate(u, theta, 1e-3).a_m / 16.0 - 1.0) < 1e-3


def test_data_that_cannot_identify_give_clear_errors() -> None:
    u = np.full(2000, 3.0)
    with pytest.raises(IdentificationError, match="input is constant"):
        estimate(u, np.linspace(0.0, 100.0, 2000), 1e-3)
    u = excitation("prbs", u0=3.0, amplitude=2.0, clock=0.02, dt=1e-3, duration=2.0)
    with pytest.raises(IdentificationError, match="did not move"):
        estimate(u, np.zeros(len(u)), 1e-3)


def test_offline_from_a_run_directory_and_design_from_the_result(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert (
        main(["identify", "--emulate", "dc-servo", "--duration", "1.5", "--excitation", "steps", "--json"])
        == 0
    )
    online = json.loads(capsys.readouterr().out)
    assert main(["identify", "--from-log", online["run_dir"], "--json"]) == 0
    offline = json.loads(capsys.readouterr().out)
    assert offline["a_m"] == online["a_m"] and offline["b_m"] == online["b_m"]
    figure = tmp_path / "identify.png"
    assert main(["identify", "--from-log", online["run_dir"], "--plot", str(figure)]) == 0
    assert figure.stat().st_size > 1000
    capsys.readouterr()
    from rig.identify.experiment import identify_from_log
    from rig.identify.plots import plot_identify

    fig = plot_identify(online["run_dir"], identify_from_log(online["run_dir"]), str(figure))
    speed, u = fig.axes
    assert "a_m" in fig._suptitle.get_text() and speed.get_title() and u.get_title()
    assert (speed.get_ylabel(), u.get_ylabel(), u.get_xlabel()) == ("speed [rad/s]", "u [V]", "time [s]")
    assert len(speed.get_lines()) == 2 and len(speed.get_legend().get_texts()) == 2
    result = tmp_path / "model.json"
    result.write_text(json.dumps(offline))
    assert (
        main(
            ["design", "dtsm", "--from-identify", str(result), "--period", "0.4e-3", "--lam", "-15", "--json"]
        )
        == 0
    )
    design = json.loads(capsys.readouterr().out)
    assert design["A_delta"][1][1] == pytest.approx(-16.0, rel=0.01)
    assert main(["identify", "--from-log", str(tmp_path)]) == 2
    assert "not a run directory" in capsys.readouterr().err


def test_bad_excitation_amplitude_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["identify", "--emulate", "dc-servo", "--u0", "1", "--amplitude", "2"]) == 2
    assert "--amplitude" in capsys.readouterr().err


def test_identify_in_cst_on_a_torque_input(
    capsys: pytest.CaptureFixture[str], tmp_path: pathlib.Path
) -> None:
    """A commercial drive has no voltage mode: the experiment replays a torque in CST, and the
    result is (3.5) with u a torque: a_m = B/J, b_m = 1/J in 1/(kg m^2), said in the result."""
    from plant_emulator.dc_motor import DCMotorParams

    motor = DCMotorParams.from_am_bm(a_m=16.0, b_m=680.0, r_r=1.0, tau_e=1e-4, b=7e-5)
    argv = ["identify", "--emulate", "dc-servo", "--input", "torque", "--param", "friction=7e-5", "--json"]
    assert main([*argv, "--duration", "5"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["input"] == "torque" and r["input_unit"] == "N m" and r["b_m_unit"] == "1/(kg m^2)"
    assert r["b_m"] == pytest.approx(1.0 / motor.j, rel=0.01)
    assert r["a_m"] == pytest.approx(motor.b / motor.j, rel=0.05)
    result = tmp_path / "ident.json"
    result.write_text(json.dumps(r))
    assert (
        main(
            ["design", "dtsm", "--from-identify", str(result), "--period", "0.4e-3", "--lam", "-15", "--json"]
        )
        == 0
    )
    assert json.loads(capsys.readouterr().out)["input"] == "torque"


def _skipping_run(tmp_path: pathlib.Path, skipped: set[int]) -> tuple[pathlib.Path, float, float]:
    """A real-time experiment's run directory whose cycles ``skipped`` had no row and sent nothing
    (the drive held the command before them): the exact motion, 4096 counts, rows as the recorder
    writes them (t = k T). Returns (run_dir, a_m, b_m)."""
    from rig.identify.estimate import simulate_positions

    a_m, b_m, dt = 16.0, 680.0, 4e-4
    planned = excitation("prbs", u0=3.0, amplitude=2.0, clock=0.02, dt=dt, duration=3.0, seed=3)
    applied = planned.copy()
    for k in sorted(skipped):
        applied[k] = applied[k - 1]  # nothing sent: the drive holds
    theta, _ = simulate_positions(np.array([a_m, b_m, 0.0, 0.0, 0.0]), applied, dt, 1)
    measured = np.floor(theta * 4096 / (2 * np.pi)) * 2 * np.pi / 4096
    rows = [k for k in range(len(planned)) if k not in skipped]
    lines = ["t,command,measurement"] + [
        f"{k * dt!r},{float(applied[k])!r},{float(measured[k])!r}" for k in rows
    ]
    (tmp_path / "samples.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "config.json").write_text(
        json.dumps({"resolved_period": dt, "controller": {"kind": "replay"}})
    )
    return tmp_path, a_m, b_m


def test_a_real_time_run_s_skipped_cycles_are_filled_in_not_closed_up(tmp_path: pathlib.Path) -> None:
    """Overruns of a real-time experiment leave no row and send nothing: read as evenly spaced, the
    rows after each gap are a period early per skipped cycle and the model is off by percents;
    on the period's grid (the command held, the position interpolated) it is recovered."""
    from rig.host.rundir import read_run
    from rig.identify.experiment import identify_from_log

    rng = np.random.default_rng(7)
    skipped = {int(k) for k in rng.choice(np.arange(10, 7000), size=150, replace=False)}
    run_dir, a_m, b_m = _skipping_run(tmp_path, skipped)
    run = read_run(run_dir)
    assert run.filled == len(skipped) and len(run.command) == 7500
    closed_up = estimate(*np.loadtxt(run_dir / "samples.csv", delimiter=",", skiprows=1)[:, 1:].T, run.period)
    assert abs(closed_up.b_m / b_m - 1.0) > 0.01  # what reading the rows as evenly spaced gave
    r = identify_from_log(run_dir)
    assert r.a_m == pytest.approx(a_m, rel=2e-3) and r.b_m == pytest.approx(b_m, rel=2e-3)
    assert r.filled_samples == len(skipped) and r.as_dict()["filled_samples"] == len(skipped)


def test_rows_whose_time_does_not_advance_by_periods_are_refused(tmp_path: pathlib.Path) -> None:
    from drivers.errors import ConfigError
    from rig.host.rundir import read_run

    run_dir, _, _ = _skipping_run(tmp_path, set())
    lines = (run_dir / "samples.csv").read_text().splitlines()
    lines[5] = lines[4]  # a row twice
    (run_dir / "samples.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ConfigError, match=r"samples.csv: t does not increase by whole periods .* at line 6"):
        read_run(run_dir)


def test_a_low_fit_is_warned_only_above_the_encoder_s_noise() -> None:
    """A multisine of 3 +- 0.5 V from 10 Hz on (3.5) through a 4096-count encoder at 0.4 ms: the
    speed varies little against one count per period, so the right model's held-out fit is low,
    but its residual is the quantisation noise q / (T sqrt(24)): not warned. A model with b_m 20 %
    off leaves more than 1.5 times that: warned, naming both figures."""
    import dataclasses
    import math

    from rig.identify.estimate import held_out_fit, simulate_positions
    from rig.identify.frequency import periodic_excitation
    from rig.identify.model_file import checks

    dt, q = 0.4e-3, 2 * math.pi / 4096
    u = periodic_excitation("multisine", u0=3.0, amplitude=0.5, dt=dt, duration=2.0, f_min=10.0)
    truth = np.array([16.0, 680.0, -30.0, 0.0, 0.0])
    theta = np.floor(simulate_positions(truth, u, dt, 1)[0] / q) * q
    r = estimate(u, theta, dt)
    assert r.b_m == pytest.approx(680.0, rel=0.01) and r.fit_percent < 70.0
    assert r.residual_rms < 1.5 * r.quantisation_rms and r.quantisation_rms == pytest.approx(
        q / (dt * 24**0.5)
    )
    assert checks(r, "replay") == (False, [])
    n_fit = int(len(u) * 0.7)
    wrong = simulate_positions(truth * [1.0, 1.2, 1.0, 1.0, 1.0], u, dt, 1)[1]
    fit, residual, floor = held_out_fit(theta, wrong, n_fit, dt)
    assert residual > 1.5 * floor
    _, warnings = checks(dataclasses.replace(r, fit_percent=fit, residual_rms=residual), "replay")
    assert len(warnings) == 1 and "times the encoder's quantisation noise" in warnings[0], warnings
