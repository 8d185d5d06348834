"""``[controller] speed = "observer"``: the VII.B servo over the emulated bus with the speed
estimated from the drive's 4096-count position, within 2x of the exact pure simulation's rms
error; a wrong value is one line naming it."""

from __future__ import annotations

import json
import pathlib

import pytest

from rig.cli import main
from rig.papers.scenarios import position_servo_run
from rig.report.metrics import rms

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def _config(tmp_path: pathlib.Path, speed: str) -> str:
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    path = tmp_path / "rig.toml"
    path.write_text(text.replace("u0 = 48.0\n", f'u0 = 48.0\nspeed = "{speed}"\n'))
    return str(path)


def test_the_observed_servo_over_the_bus(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--config", _config(tmp_path, "observer"), "--emulate", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    exact = position_servo_run(load=1000.0, full_motor=True, t_end=3.0)
    assert summary["cycles"] == 7500
    assert summary["rms_error"] < 2.0 * rms(exact.error), (summary["rms_error"], rms(exact.error))


def test_a_wrong_speed_source_is_named(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--config", _config(tmp_path, "psychic"), "--emulate"]) == 2
    err = capsys.readouterr().err
    needle = "[controller] position-servo: speed = 'psychic': expected one of drive, observer"
    assert needle in err and len(err.strip().splitlines()) == 1, err
