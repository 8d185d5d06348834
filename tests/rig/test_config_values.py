"""Bad values in a rig configuration: one line naming the file, the key and the value, exit code 2,
and nothing opened (no bus, no emulated world, no run directory); runs without limits."""

from __future__ import annotations

import json
import math
import pathlib
import re
import shutil

import pytest

from drivers.errors import ConfigError
from rig.cli import main
from rig.config import load_config
from rig.config.checks import require_limits

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
EXAMPLE = EXAMPLES / "dc_servo_position.toml"

#: (what the example says, what the bad configuration says instead, what the error line must contain)
BAD = {
    "period-as-string": (
        "[run]\n",
        '[run]\nperiod = "0"\n',
        "[run]: period = '0': expected float, not a string",
    ),
    "period-inf": ("[run]\n", "[run]\nperiod = inf\n", "[run] period = inf"),
    "period-tiny": ("[run]\n", "[run]\nperiod = 1e-300\n", "[run] period = 1e-300"),
    "duration-inf": ("duration = 3.0", "duration = inf", "[run] duration = inf"),
    "duration-nan": ("duration = 3.0", "duration = nan", "[run]: duration = nan: expected a number, not NaN"),
    "period-nan": ("[run]\n", "[run]\nperiod = nan\n", "[run]: period = nan: expected a number, not NaN"),
    "period-zero-string": ("[run]\n", '[run]\nperiod = "0.001"\n', "[run]: period = '0.001': expected float"),
    "missed-sample": ("[run]\n", '[run]\nmissed_sample = "skip"\n', "missed_sample = 'skip'"),
    "duration-zero": ("duration = 3.0", "duration = 0.0", "[run] duration = 0.0"),
    "name-escapes": ('name = "dc-servo-position"', 'name = "../../escaped"', "[run] name = '../../escaped'"),
    "name-absolute": ('name = "dc-servo-position"', 'name = "/tmp/escaped"', "[run] name = '/tmp/escaped'"),
    "name-backslash": ('name = "dc-servo-position"', 'name = "..\\\\x"', "[run] name = '..\\\\x'"),
    "sync-rpdo-as-string": ("sync_rpdo = false", 'sync_rpdo = "false"', "sync_rpdo = 'false': expected true"),
    "heartbeat-timeout-negative": (
        "heartbeat_timeout = 0.0",
        "heartbeat_timeout = -1.0",
        "[[axis]] 'motor' limits heartbeat_timeout = -1.0",
    ),
    "heartbeat-timeout-inf": (
        "heartbeat_timeout = 0.0",
        "heartbeat_timeout = inf",
        "[[axis]] 'motor' limits heartbeat_timeout = inf",
    ),
    "host-timeout-negative": ("latency = 0.0", "host_timeout = -0.5", "[[axis]] 'motor' host_timeout = -0.5"),
    "enable-timeout-inf": ("latency = 0.0", "enable_timeout = inf", "[[axis]] 'motor' enable_timeout = inf"),
    "sdo-timeout-negative": ("latency = 0.0", "sdo_timeout = -1.0", "[[axis]] 'motor' sdo_timeout = -1.0"),
    "latency-inf": ("latency = 0.0", "latency = inf", "[[axis]] 'motor' latency = inf"),
    "bus-heartbeat-inf": ("port = 29536", "port = 29536\nheartbeat = inf", "[bus] heartbeat = inf"),
    "bus-heartbeat-negative": ("port = 29536", "port = 29536\nheartbeat = -0.1", "[bus] heartbeat = -0.1"),
    "bus-port": ("port = 29536", "port = 70000", "[bus] port = 70000"),
    "command-limit-zero": ("command = 48.0", "command = 0.0", "limits command = 0.0"),
    "command-limit-negative": ("command = 48.0", "command = -48.0", "limits command = -48.0"),
    "speed-limit-negative": ("speed = 300.0", "speed = -300.0", "limits speed = -300.0"),
    "current-limit-zero": ("current = 30.0", "current = 0.0", "limits current = 0.0"),
    "position-window-empty": ("position_min = -1.0", "position_min = 12.0", "limits position_min = 12.0"),
    "position-window-inverted": ("position_max = 12.0", "position_max = -2.0", "position_max = -2.0"),
    "watchdog-negative": (
        "watchdog_periods = 3",
        "watchdog_periods = 3\nwatchdog = -0.1",
        "[[axis]] 'motor' limits watchdog = -0.1",
    ),
    "watchdog-inf": ("watchdog_periods = 3", "watchdog_periods = 3\nwatchdog = inf", "limits watchdog = inf"),
    "watchdog-nan": (
        "watchdog_periods = 3",
        "watchdog_periods = 3\nwatchdog = nan",
        "limits: watchdog = nan: expected a number",
    ),
    "heartbeat-timeout-nan": (
        "heartbeat_timeout = 0.0",
        "heartbeat_timeout = nan",
        "[[axis]] 'motor' limits: heartbeat_timeout = nan",
    ),
    "watchdog-zero": ("watchdog_periods = 3", "watchdog_periods = 0", "limits watchdog_periods = 0"),
    "reference-duration-nan": ("duration = 1.0 ", "duration = nan ", "[reference]: duration = nan"),
    "reference-duration-inf": ("duration = 1.0 ", "duration = inf ", "[reference] duration = inf"),
    "reference-distance-inf": ("distance = 10.0", "distance = inf", "[reference] distance = inf"),
    "frame-loss": ("[controller]", "[faults]\nframe_loss = 2.0\n\n[controller]", "[faults] frame_loss = 2.0"),
    "fault-time-negative": (
        "[controller]",
        "[faults]\ntpdo_stall_at = -1.0\n\n[controller]",
        "tpdo_stall_at = -1.0",
    ),
    "emulator-param-string": (
        'load = "pulse:0.0346:1.5:3"',
        'a_m = "16"',
        "[emulator.params] of preset dc-servo: a_m = '16': expected float, not a string",
    ),
    "emulator-param-negative": (
        'load = "pulse:0.0346:1.5:3"',
        "a_m = -16.0",
        "[emulator.params] of preset dc-servo a_m = -16.0: must be > 0 [1/s]",
    ),
    "emulator-param-load": (
        'load = "pulse:0.0346:1.5:3"',
        'load = "step:x"',
        "of preset dc-servo load = 'step:x': profile 'step:x': term 'step:x'",
    ),
    "emulator-param-period": (
        'load = "pulse:0.0346:1.5:3"',
        "period = 1e-300",
        "[emulator.params] of preset dc-servo period = 1e-300: must be a period of 1e-05 .. 10 s",
    ),
    "emulator-param-huge-int": (
        'load = "pulse:0.0346:1.5:3"',
        "counts_per_rev = 100000000000",
        "counts_per_rev = 100000000000: must be 1 .. 2147483647 increments/rev",
    ),
    "limit-speed-inf": ("speed = 300.0", "speed = inf", "limits speed = inf: must be a finite number"),
    "limit-position-inf": ("position_max = 12.0", "position_max = inf", "limits position_max = inf"),
    "controller-sigma-inf": ("sigma = 10.0", "sigma = inf", "[controller] position-servo sigma = inf"),
    "controller-u0-inf": ("u0 = 48.0", "u0 = -inf", "[controller] position-servo u0 = -inf"),
    "bus-interface-typo": (
        'interface = "socketcand"',
        'interface = "socketcnd"',
        "[bus] interface = 'socketcnd': not a python-can interface; known: ",
    ),
    "emulator-param-table": (
        'load = "pulse:0.0346:1.5:3"',
        "a_m = {x = 1}",
        "a_m = {'x': 1}: expected a number",
    ),
}


def _config(
    tmp_path: pathlib.Path, old: str = "", new: str = "", example: pathlib.Path = EXAMPLE
) -> pathlib.Path:
    text = example.read_text().replace('output = "runs"', f'output = "{tmp_path / "runs"}"')
    assert old in text, old
    path = tmp_path / "rig.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_value_is_one_line_naming_it_and_opens_nothing(
    case: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    old, new, needle = BAD[case]
    path = _config(tmp_path, old, new)
    assert main(["run", "--config", str(path), "--emulate"]) == 2
    out = capsys.readouterr()
    assert out.out == "" and len(out.err.splitlines()) == 1, out.err
    assert out.err.startswith(f"rig: {path}: ") and needle in out.err
    assert not opened and not (tmp_path / "runs").exists()
    assert not list(tmp_path.parent.glob("escaped*")) and not list(pathlib.Path("/tmp").glob("escaped-*"))


def test_an_output_that_is_a_file_is_named(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    out = tmp_path / "runs"
    out.write_text("a file where the runs would go\n")
    path = _config(tmp_path)
    assert main(["run", "--config", str(path), "--emulate"]) == 2
    err = capsys.readouterr().err
    assert err == f"rig: {path}: [run] output = '{out}': is a file, not a folder\n"
    below = _config(tmp_path, f'output = "{out}"', f'output = "{out / "deeper"}"')
    assert main(["run", "--config", str(below), "--emulate"]) == 2
    assert f"is below the file {out}, not a folder" in capsys.readouterr().err
    assert not opened


def test_a_run_stays_in_its_output_folder(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _config(tmp_path, 'name = "dc-servo-position"', 'name = "..-odd but plain"')
    assert main(["run", "--config", str(path), "--emulate", "--duration", "0.02", "--json"]) == 0
    (run_dir,) = (tmp_path / "runs").iterdir()
    assert run_dir.name.startswith("..-odd but plain-") and (run_dir / "summary.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rig.toml", "runs"]


def _without_limits(tmp_path: pathlib.Path) -> pathlib.Path:
    example = EXAMPLES / "dc_servo_speed_csv.toml"
    text = re.sub(r"\[axis\.limits\][^\[]*", "", example.read_text())
    assert "limits" not in text
    path = tmp_path / "bare.toml"
    path.write_text(text.replace('output = "runs"', f'output = "{tmp_path / "runs"}"'))
    return path


def test_a_commanded_axis_without_limits_needs_no_limits(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _without_limits(tmp_path)
    assert main(["run", "--config", str(path), "--emulate", "--duration", "0.05"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "'motor': commanded without any limit" in err
    assert "--no-limits" in err and not (tmp_path / "runs").exists()
    assert main(["run", "--config", str(path), "--emulate", "--duration", "0.05", "--no-limits"]) == 0


def test_one_limit_is_enough_and_feedback_axes_need_none(tmp_path: pathlib.Path) -> None:
    path = _without_limits(tmp_path)
    path.write_text(path.read_text().replace("[controller]", "[axis.limits]\nspeed = 250.0\n\n[controller]"))
    require_limits(load_config(path))
    dyno = load_config(EXAMPLES / "dyno_speed_load.toml")  # the encoder is read, never commanded
    require_limits(dyno)


def test_a_profile_commanded_axis_needs_limits_too(tmp_path: pathlib.Path) -> None:
    text = (EXAMPLES / "dyno_speed_load.toml").read_text()
    path = tmp_path / "dyno.toml"
    path.write_text(text.replace("command = 0.5           # N m\nspeed = 300.0", "watchdog_periods = 3"))
    with pytest.raises(ConfigError, match=r"\[\[axis\]\] 'load': commanded without any limit"):
        require_limits(load_config(path))


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.toml")))
def test_every_example_has_limits(name: str) -> None:
    """``rig run --config examples/...`` (the README's commands) needs no --no-limits: each
    commanded axis has a finite limit, and the check that refuses one without is what passes."""
    cfg = load_config(EXAMPLES / name)
    require_limits(cfg)
    commanded = {*cfg.controller.commands, *(a.name for a in cfg.axes if a.profile)}
    for axis in (a for a in cfg.axes if a.name in commanded):
        kinds = ("command", "speed", "current", "position_min", "position_max")
        assert any(math.isfinite(getattr(axis.limits, k)) for k in kinds), (name, axis.name, axis.limits)


def test_faults_from_the_command_line_are_text_and_checked(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--fault stays text (a fraction such as 1/100 is fine); its values are checked like the file's."""
    path = _config(tmp_path)
    assert main(["run", "--config", str(path), "--fault", "frame_loss=2", "--emulate"]) == 2
    assert capsys.readouterr().err == "rig run: --fault frame_loss = 2.0: must be a fraction in [0, 1)\n"
    argv = ["run", "--config", str(path), "--fault", "frame_loss=1/100", "--emulate", "--duration", "0.02"]
    assert main(argv) == 0


@pytest.mark.parametrize("duration", ["inf", "nan", "0", "-1"])
def test_a_bad_duration_on_the_command_line_is_one_line(
    duration: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    path = _config(tmp_path)
    assert main(["run", "--config", str(path), "--emulate", "--duration", duration]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--duration" in err and "Traceback" not in err, err
    assert not opened and not (tmp_path / "runs").exists()


@pytest.mark.parametrize(
    ("value", "needle"),
    [
        ("accel = -5.0", "[emulator.inverter] accel = -5.0: must be > 0 rad/s^2"),
        ("accel = inf", "[emulator.inverter] accel = inf: must be a finite number > 0 rad/s^2"),
        ("slip = -1.0", "[emulator.inverter] slip = -1.0: must be >= 0 rad/s"),
        (
            "comm_loss_timeout = -1.0",
            "[emulator.inverter] comm_loss_timeout = -1.0: must be > 0 s (inf: off)",
        ),
        (
            "comm_loss_timeout = 0.001",
            "is not shorter than the emulated inverter's comm_loss_timeout 0.001 s",
        ),
        ('accel = "fast"', "[emulator.inverter]: accel = 'fast': expected float, not a string"),
    ],
)
def test_a_bad_emulated_inverter_value_opens_nothing(
    value: str, needle: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    path = _config(tmp_path, "accel = 100.0", value, example=EXAMPLES / "modbus_inverter_speed.toml")
    assert main(["run", "--config", str(path), "--emulate"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rig: {path}: ") and needle in err, err
    assert not opened and not (tmp_path / "runs").exists()


def test_an_infinite_law_parameter_is_refused_not_a_nan_stop_at_cycle_0(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    """dq-current with f_line = inf ran, and stopped at cycle 0 on a NaN command."""
    grid = EXAMPLE.parent / "grid_dq_current.toml"
    path = _config(tmp_path, "f_line = 50.0", "f_line = inf", example=grid)
    assert main(["run", "--config", str(path), "--emulate"]) == 2
    err = capsys.readouterr().err
    assert err == f"rig: {path}: [controller] dq-current f_line = inf: must be a finite number\n"
    assert not opened


def test_the_run_period_is_the_emulated_devices_period(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """[run] period with --emulate: the emulated devices step at it, so a run at 1 ms is the run
    with the preset's period set to 1 ms (before, the plant went on at its 0.4 ms a SYNC: 2.5
    times slow, rms error 0.728 rad against 2.9 mrad)."""
    figures = []
    for old, new in (
        ("[run]\n", "[run]\nperiod = 1e-3\n"),
        ('load = "pulse', 'period = 1e-3\nload = "pulse'),
    ):
        path = _config(tmp_path, "duration = 3.0", "duration = 0.3")
        path.write_text(path.read_text().replace(old, new, 1))
        assert main(["run", "--config", str(path), "--emulate", "--json"]) == 0
        summary = json.loads(capsys.readouterr().out)
        assert summary["cycles"] == 300
        figures.append((summary["rms_error"], summary["max_error"]))
    assert figures[0] == figures[1] and figures[0][0] < 0.01, figures


def test_a_run_period_the_emulated_devices_cannot_take_is_one_line(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    """Another period in [emulator.params] beside [run] period, or a preset whose period is not its
    own parameter (grid-converter's ratio/f_line): one line naming both, nothing opened."""
    grid = _config(tmp_path, "[run]\n", "[run]\nperiod = 1e-3\n", EXAMPLES / "grid_dq_current.toml")
    grid = grid.rename(tmp_path / "grid.toml")
    path = _config(tmp_path, 'load = "pulse', 'period = 4e-4\nload = "pulse')
    path.write_text(path.read_text().replace("[run]\n", "[run]\nperiod = 1e-3\n", 1))
    for bad, needle in ((path, "[emulator.params] period of preset dc-servo"), (grid, "ratio/f_line")):
        assert main(["run", "--config", str(bad), "--emulate"]) == 2
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and err.startswith(f"rig: {bad}: [run] period = 0.001 s, but"), err
        assert needle in err, err
    assert not opened


def test_an_unknown_register_map_is_one_line_at_load(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    """A Modbus axis's map is checked with the file (it was a traceback from the emulated inverter)."""
    modbus = EXAMPLES / "modbus_inverter_speed.toml"
    path = _config(tmp_path, 'map = "abb-drives-profile"', 'map = "nope"', modbus)
    assert main(["run", "--config", str(path), "--emulate"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"rig: {path}: [[axis]] 'inverter' map = 'nope': unknown Modbus map 'nope'"), err
    assert not opened


def test_the_lazy_package_exports_exactly_the_schema_s_names() -> None:
    """rig.config names the schema's and the loader's exports without importing them (rig
    --version stays light): the lists must not drift apart."""
    import rig.config
    import rig.config.load
    import rig.config.schema

    homes = {name: module for module in (rig.config.schema, rig.config.load) for name in module.__all__}
    assert sorted(rig.config.__all__) == sorted(homes)
    assert all(getattr(rig.config, name) is homes[name].__dict__[name] for name in rig.config.__all__)


def test_an_axis_s_eds_is_found_from_its_file_s_folder(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A relative ``eds`` is taken from the configuration's folder, as ``design`` and ``[emulator]
    device`` are, wherever rig runs (examples/dual_axis_ip.toml names the twin's
    ../plant_emulator/devices/dual-axis.eds): it was taken from the working folder."""
    root = pathlib.Path(__file__).resolve().parents[2]
    folder = tmp_path / "a" / "b"
    folder.mkdir(parents=True)
    shutil.copy(root / "plant_emulator" / "devices" / "dual-axis.eds", tmp_path / "a" / "twin.eds")
    text = (root / "examples" / "dual_axis_ip.toml").read_text()
    (folder / "rig.toml").write_text(text.replace("../plant_emulator/devices/dual-axis.eds", "../twin.eds"))
    monkeypatch.chdir(tmp_path)
    cfg = load_config(folder / "rig.toml")
    for name in ("arm", "feeder"):
        assert pathlib.Path(cfg.axis(name).eds).resolve() == tmp_path / "a" / "twin.eds"
