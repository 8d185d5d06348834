"""Every column of a run's samples is described: columns.json beside samples.csv and
column_unit/column_meaning in samples.mat, for each kind of law and axis."""

from __future__ import annotations

import json
import pathlib

import pytest
import scipy.io

from rig.cli import main

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("example", "units"),
    [
        (
            "dc_servo_position.toml",
            {"reference": "rad", "command": "V", "g": "V s", "motor.velocity": "rad/s"},
        ),
        ("dc_servo_speed_csv.toml", {"reference": "rad/s", "command": "rad/s", "motor.current": "A"}),
        ("grid_dq_current.toml", {"reference": "A", "u_d": "V"}),
    ],
)
def test_every_column_has_a_unit_and_a_meaning(
    example: str, units: dict[str, str], tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "rig.toml"
    config.write_text(
        (ROOT / "examples" / example).read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    )
    assert main(["run", "--config", str(config), "--emulate", "--duration", "0.1", "--json"]) == 0
    run_dir = pathlib.Path(json.loads(capsys.readouterr().out)["run_dir"])
    header = (run_dir / "samples.csv").read_text().splitlines()[0].split(",")
    docs = json.loads((run_dir / "columns.json").read_text())
    assert list(docs) == header
    assert all(d["meaning"] and "an internal of the law" not in d["meaning"] for d in docs.values()), docs
    assert {k: docs[k]["unit"] for k in units} == units
    mat = scipy.io.loadmat(run_dir / "samples.mat")
    assert str(mat["column_unit"]["t"][0, 0][0]) == "s"
