"""``rig export``: a run's samples as MF4, Parquet, MAT and CSV, each read back by a reader nobody
here wrote (asammdf, pyarrow, scipy.io, numpy) with its channels, values and units."""

from __future__ import annotations

import dataclasses
import json
import pathlib

import numpy as np
import pytest

from rig.cli import main
from rig.config import load_config
from rig.host.rundir import read_samples

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """A short run of the servo example over the emulated bus."""
    from rig.host.session import Session

    cfg = load_config(EXAMPLE)
    out = tmp_path_factory.mktemp("export")
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(out), duration=0.2))
    with Session(cfg, emulate=True) as session:
        session.start()
        summary = session.run()
    return pathlib.Path(summary["run_dir"])


def _export(run_dir: pathlib.Path, fmt: str, capsys: pytest.CaptureFixture[str]) -> pathlib.Path:
    assert main(["export", str(run_dir), "--format", fmt]) == 0
    written = pathlib.Path(capsys.readouterr().out.split("written to ", 1)[1].strip())
    assert written == run_dir.parent / f"{run_dir.name}.{fmt}" and written.is_file()
    return written


def _recorded(run_dir: pathlib.Path) -> tuple[dict[str, np.ndarray], dict[str, dict[str, str]]]:
    _config, columns = read_samples(run_dir)
    return columns, json.loads((run_dir / "columns.json").read_text())


@pytest.mark.export  # asammdf: the export extra, apart (python-can imports it on `import can`)
def test_mf4_read_by_asammdf_has_every_channel_with_its_unit(
    run_dir: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import asammdf

    columns, docs = _recorded(run_dir)
    with asammdf.MDF(_export(run_dir, "mf4", capsys)) as mdf:
        assert mdf.version.startswith("4.")
        names = {name for name in mdf.channels_db if name != "time"}
        assert names == set(columns) - {"t"}
        for name in ("measurement", "command", "motor.velocity", "g"):
            signal = mdf.get(name)
            assert signal.unit == docs[name]["unit"] and signal.comment == docs[name]["meaning"], name
            assert np.array_equal(signal.samples, columns[name])
            assert np.array_equal(signal.timestamps, columns["t"])
    assert docs["motor.velocity"]["unit"] == "rad/s" and docs["command"]["unit"] == "V"


def test_parquet_read_by_pyarrow_has_every_column_with_its_unit(
    run_dir: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import pyarrow.parquet as pq

    columns, docs = _recorded(run_dir)
    table = pq.read_table(_export(run_dir, "parquet", capsys))
    assert table.column_names == list(columns)
    for name in columns:
        assert np.array_equal(table.column(name).to_numpy(), columns[name]), name
        meta = table.schema.field(name).metadata
        assert meta[b"unit"].decode() == docs[name]["unit"], name
    config = json.loads(table.schema.metadata[b"rig.config"])
    assert config["run"]["name"] == "dc-servo-position"


def test_mat_and_csv_read_back_with_scipy_and_numpy(
    run_dir: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import scipy.io

    columns, _docs = _recorded(run_dir)
    mat = scipy.io.loadmat(_export(run_dir, "mat", capsys), squeeze_me=True)
    for name in columns:
        assert np.array_equal(mat[name.replace(".", "_")], columns[name]), name
    assert mat["column_unit"]["motor_velocity"].item() == "rad/s"
    csv = np.genfromtxt(_export(run_dir, "csv", capsys), delimiter=",", names=True)
    assert np.array_equal(csv["measurement"], columns["measurement"])


def test_a_run_without_its_close_is_exported_too(
    run_dir: pathlib.Path, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run killed before its close has samples.csv but no samples.mat: the export writes one."""
    import shutil

    import scipy.io

    killed = tmp_path / run_dir.name
    killed.mkdir()
    for name in ("config.json", "columns.json", "samples.csv"):
        shutil.copy(run_dir / name, killed / name)
    out = tmp_path / "elsewhere.mat"
    assert main(["export", str(killed), "--format", "mat", "--output", str(out)]) == 0
    assert f"written to {out}" in capsys.readouterr().out
    assert len(scipy.io.loadmat(out)["t"].ravel()) == len(read_samples(killed)[1]["t"])


def test_bad_exports_are_one_line_and_exit_2(
    run_dir: pathlib.Path, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["export", str(tmp_path), "--format", "mf4"]) == 2
    assert "not a run directory with config.json and samples.csv" in capsys.readouterr().err
    assert main(["export", str(run_dir), "--format", "xlsx"]) == 2
    assert "xlsx" in capsys.readouterr().err
    assert main(["export", str(run_dir), "--format", "csv", "--output", str(run_dir / "samples.csv")]) == 2
    assert "is the run's samples.csv" in capsys.readouterr().err
