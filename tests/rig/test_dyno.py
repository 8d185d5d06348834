"""The first multi-axis bench: the emulated dyno (motor under test, encoder, load machine on one shaft)."""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import pytest

from rig.config import load_config
from rig.host.rundir import read_samples
from rig.host.session import Session

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dyno_speed_load.toml"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, object], dict[str, np.ndarray]]:
    cfg = load_config(EXAMPLE)
    out = tmp_path_factory.mktemp("dyno")
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(out)))
    with Session(cfg, emulate=True, duration=5.0) as session:
        session.start()
        summary = session.run()
    _, columns = read_samples(summary["run_dir"])  # type: ignore[arg-type]
    return summary, columns


def test_three_axes_one_law_one_sync(run) -> None:  # type: ignore[no-untyped-def]
    summary, columns = run
    assert summary["safe_stop_reason"] is None and summary["cycles"] == 12_500
    assert set(summary["axes"]) == {"motor", "encoder", "load"}
    for column in ("motor.position", "motor.velocity", "encoder.position", "encoder.velocity", "load.torque"):
        assert column in columns
    assert "motor.command" in columns and "load.command" in columns


def test_the_encoder_and_the_drives_see_one_shaft(run) -> None:  # type: ignore[no-untyped-def]
    _, c = run
    quantum = 2 * np.pi / 65536  # the example's counts per revolution
    assert np.max(np.abs(c["encoder.position"] - c["motor.position"])) <= 1.01 * quantum
    assert np.max(np.abs(c["load.position"] - c["motor.position"])) <= 1.01 * quantum


def test_the_load_machine_applies_the_profile_in_the_same_cycle(run) -> None:  # type: ignore[no-untyped-def]
    _, c = run
    t, command, torque = c["t"], c["load.command"], c["load.torque"]
    on = (t >= 2.0) & (t < 4.0)
    assert np.all(command[on] < 0.0) and np.all(command[(t < 2.0) | (t >= 4.0)] == 0.0)
    # synchronous RPDO: the command of cycle k is the torque the drive reports from cycle k + 2 on
    # (applied at SYNC k + 1, latched at SYNC k + 2), to the per-mille quantum of its rated torque
    k = np.nonzero(on)[0][10]
    assert torque[k + 2] == pytest.approx(command[k], rel=2e-3)


def test_the_speed_law_holds_the_speed_against_the_load(run) -> None:  # type: ignore[no-untyped-def]
    _, c = run
    t, w = c["t"], c["encoder.velocity"]
    reference = c["reference"]
    settled = (t > 1.5) & (t < 2.0)
    quantum = 2 * np.pi / 65536 / 0.4e-3  # the speed by difference: 0.24 rad/s
    assert np.max(np.abs(w[settled] - reference[settled])) <= 2.01 * quantum  # one or two quanta
    loaded = (t > 2.2) & (t < 4.0)  # the integral has taken up the load step
    assert np.max(np.abs(w[loaded] - reference[loaded])) <= 2.01 * quantum  # one or two quanta
    assert np.min(w[(t > 2.0) & (t < 2.3)]) < reference[-1] - 1.0  # the load step did bite
