"""identify -> design -> run without copying numbers: identification.json in the run directory,
``rig design dtsm --from-identify`` on it (dt from it), ``[controller] design = "FILE"``; and
the warnings for closed-loop data and a poor held-out fit (``--strict``: exit 5)."""

from __future__ import annotations

import contextlib
import io
import json
import pathlib

import pytest

from drivers.errors import ConfigError
from rig.cli import main
from rig.config import load_config

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "dc_servo_position.toml"


@pytest.fixture(scope="module")
def identified() -> pathlib.Path:
    """The run directory of an open-loop identification of a_m = 23.5, b_m = 412."""
    argv = ["identify", "--emulate", "dc-servo", "--param", "plant.a_m=23.5", "--param", "plant.b_m=412"]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main([*argv, "--duration", "2", "--u0", "8", "--amplitude", "5", "--json"]) == 0
    return pathlib.Path(json.loads(buf.getvalue())["run_dir"]).resolve()  # the cwd is the test's


def test_identify_writes_identification_json(identified: pathlib.Path) -> None:
    doc = json.loads((identified / "identification.json").read_text())
    keys = {"a_m", "b_m", "a_m_stderr", "b_m_stderr", "a_m_ci95", "b_m_ci95", "dt", "delay", "offset"}
    assert keys | {"fit_percent", "closed_loop", "warnings"} <= set(doc)
    assert doc["a_m"] == pytest.approx(23.5, rel=5e-3) and doc["b_m"] == pytest.approx(412.0, rel=5e-3)
    assert doc["dt"] == pytest.approx(0.4e-3) and doc["delay"] == pytest.approx(doc["delay_samples"] * 0.4e-3)
    assert doc["closed_loop"] is False and doc["warnings"] == []


def test_design_from_the_run_directory_takes_dt_from_it(
    identified: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["design", "dtsm", "--from-identify", str(identified), "--lam", "-15", "--error-space", "--json"]
    assert main(argv) == 0
    design = json.loads(capsys.readouterr().out)
    assert design["dt"] == pytest.approx(0.4e-3) and design["lam"] == -15.0
    assert design["a_m"] == pytest.approx(23.5, rel=5e-3) and design["input"] == "voltage"
    assert design["A_delta"][1][1] == pytest.approx(-23.5, rel=0.01)
    assert main([*argv, "--period", "1e-3"]) == 0  # --period given: it wins
    assert json.loads(capsys.readouterr().out)["dt"] == 1e-3


def _config(tmp_path: pathlib.Path, design: str, extra: str = "") -> pathlib.Path:
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    text = text.replace("a_m = 16.0\nb_m = 680.0\nlam = -15.0\n", f'design = "{design}"\n{extra}')
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_a_run_takes_its_model_from_the_design_file(
    identified: pathlib.Path, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["design", "dtsm", "--from-identify", str(identified), "--lam", "-12", "--error-space", "--json"]
    assert main(argv) == 0
    (tmp_path / "design.json").write_text(capsys.readouterr().out)
    cfg = load_config(_config(tmp_path, "design.json"))  # relative to the configuration's folder
    p = cfg.controller.params
    assert p["a_m"] == pytest.approx(23.5, rel=5e-3) and p["lam"] == -12.0
    assert (
        main(["run", "--config", str(_config(tmp_path, "design.json")), "--emulate", "--duration", "0.2"])
        == 0
    )
    cfg = load_config(_config(tmp_path, str(identified)))  # an identification: a_m, b_m; lam the law's
    assert (
        cfg.controller.params["b_m"] == pytest.approx(412.0, rel=5e-3) and "lam" not in cfg.controller.params
    )


def test_design_file_mistakes_are_named(identified: pathlib.Path, tmp_path: pathlib.Path) -> None:
    with pytest.raises(ConfigError, match=r"a_m also given in \[controller\]"):
        load_config(_config(tmp_path, str(identified), "a_m = 16.0\n"))
    with pytest.raises(ConfigError, match=r"design = 'missing.json'.*missing.json"):
        load_config(_config(tmp_path, "missing.json"))
    (tmp_path / "design.json").write_text(json.dumps({"a_m": 16.0, "b_m": 680.0, "lam": -15.0, "dt": 1e-3}))
    text = _config(tmp_path, "design.json").read_text().replace("[run]\n", "[run]\nperiod = 0.0004\n")
    (tmp_path / "rig.toml").write_text(text)
    with pytest.raises(ConfigError, match=r"designed for T = 0.001 s, but \[run\] period = 0.0004 s"):
        load_config(tmp_path / "rig.toml")
    (tmp_path / "design.json").write_text(json.dumps({"a_m": 16.0, "b_m": 1e4, "input": "torque"}))
    with pytest.raises(ConfigError, match=r"its input is a torque, so axis 'motor' must be in mode = 'cst'"):
        load_config(_config(tmp_path, "design.json"))


def test_closed_loop_data_warn_and_strict_exits_5(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A closed-loop servo log (the example's position servo on a_m = 23.5, b_m = 412) identified
    offline gives a_m about 2.8 and a held-out fit far below 0 %: warned for both, and with
    --strict exit 5; identification.json says so. Without Coulomb friction: with it the servo
    sticks at rest in the held-out part, whose constant speed leaves no fit to measure."""
    config = tmp_path / "rig.toml"
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    params = "[emulator.params]\na_m = 23.5\nb_m = 412.0\ncoulomb = 0.0\n"
    config.write_text(text.replace("[emulator.params]\n", params))
    assert main(["run", "--config", str(config), "--emulate", "--json"]) == 0
    run_dir = json.loads(capsys.readouterr().out)["run_dir"]
    assert main(["identify", "--from-log", run_dir]) == 0
    err = capsys.readouterr().err
    assert "closed loop (controller 'position-servo')" in err and "the held-out fit is -" in err, err
    assert main(["identify", "--from-log", run_dir, "--strict", "--json"]) == 5
    doc = json.loads(capsys.readouterr().out)
    assert doc["closed_loop"] is True and doc["warnings"]
    assert json.loads((pathlib.Path(run_dir) / "identification.json").read_text())["closed_loop"] is True
