"""The Modbus inverter under ``rig run``'s own path: TCP, and RTU over a pseudo-terminal pair."""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import pytest

from rig.config import load_config, replace_axis
from rig.host.rundir import read_samples
from rig.host.session import Session

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "modbus_inverter_speed.toml"


@pytest.mark.parametrize("line", ["tcp", "rtu"])
def test_the_inverter_reaches_its_speed_and_ends_stopped(line: str, tmp_path: pathlib.Path) -> None:
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path)))
    if line == "rtu":  # with --emulate, the serial line is a pty pair with the inverter at its far end
        cfg = replace_axis(cfg, "inverter", host="", serial="/dev/ttyS-emulated", baudrate=115200)
    with Session(cfg, emulate=True, duration=1.0) as session:
        session.start()
        summary = session.run()
        model, _ = session.emulation.inverters["inverter"]  # type: ignore[union-attr]
        assert not model.running  # the run ended with the inverter stopped
    assert summary["safe_stop_reason"] is None and summary["cycles"] == 100
    _, columns = read_samples(summary["run_dir"])
    speed = columns["inverter.velocity"]
    assert speed[-1] == pytest.approx(50.0, abs=0.5)  # 100 rad/s^2 ramp from 0.1 s: at 50 by 0.6 s
    assert np.all(columns["inverter.command"][columns["t"] >= 0.1] == 50.0)
    assert summary["axes"]["inverter"]["max_abs_current"] > 0.0
