"""Hostile input files: each is one line on stderr naming the file, exit code 2, nothing opened.

The rig configuration, a device profile, an EDS, a run directory read back and a ``rig
identify`` result, each as junk bytes, UTF-16, a FIFO (no writer: reading it would block),
``/dev/zero`` (endless), a directory, nesting thousands deep and a file over the limit.
"""

from __future__ import annotations

import json
import os
import pathlib
import random
from collections.abc import Callable

import pytest

from drivers.errors import ConfigError
from drivers.files import CONFIG_LIMIT, MAX_DEPTH, read_json, read_toml
from rig.cli import main

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
EXAMPLE = EXAMPLES / "dc_servo_position.toml"


def _junk(p: pathlib.Path) -> pathlib.Path:
    p.write_bytes(random.Random(16).randbytes(100_000))
    return p


def _junk_10mb(p: pathlib.Path) -> pathlib.Path:
    p.write_bytes(random.Random(16).randbytes(10 << 20))
    return p


def _utf16(p: pathlib.Path) -> pathlib.Path:
    p.write_text('[run]\nduration = 1.0\nname = "x"\n', encoding="utf-16")
    return p


def _fifo(p: pathlib.Path) -> pathlib.Path:
    os.mkfifo(p)  # nobody writes: an open for reading without O_NONBLOCK would wait for ever
    return p


def _deep(p: pathlib.Path) -> pathlib.Path:
    p.write_text("a = " + "[" * 10_000 + "]" * 10_000 + "\n")
    return p


def _deep_json(p: pathlib.Path) -> pathlib.Path:
    p.write_text('{"a_m": ' + "[" * 10_000 + "]" * 10_000 + "}")
    return p


def _huge(p: pathlib.Path) -> pathlib.Path:
    p.write_text("# a comment line, valid TOML and UTF-8, only far too much of it\n" * 40_000)
    return p


def _zero(p: pathlib.Path) -> pathlib.Path:
    return pathlib.Path("/dev/zero")


def _directory(p: pathlib.Path) -> pathlib.Path:
    p.mkdir()
    return p


HOSTILE: dict[str, Callable[[pathlib.Path], pathlib.Path]] = {
    "junk": _junk,
    "junk-10mb": _junk_10mb,
    "utf16": _utf16,
    "fifo": _fifo,
    "dev-zero": _zero,
    "deep": _deep,
    "huge": _huge,
    "directory": _directory,
}


def _skip_unless_here(kind: str) -> None:
    """Skip where the system has no FIFOs or no /dev/zero."""
    if kind == "fifo" and not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    if kind == "dev-zero" and not pathlib.Path("/dev/zero").exists():
        pytest.skip("no /dev/zero here")


def _one_line_naming(capsys: pytest.CaptureFixture[str], path: pathlib.Path) -> str:
    out = capsys.readouterr()
    lines = out.err.splitlines()
    assert len(lines) == 1, out.err
    assert str(path) in lines[0] and "Traceback" not in out.err
    assert out.out == ""
    return lines[0]


@pytest.mark.timeout(20)
@pytest.mark.parametrize("kind", sorted(HOSTILE))
def test_hostile_configuration(
    kind: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    _skip_unless_here(kind)
    path = HOSTILE[kind](tmp_path / "rig.toml")
    assert main(["run", "--config", str(path), "--emulate"]) == 2
    _one_line_naming(capsys, path)
    assert not opened and not (tmp_path / "runs").exists()


@pytest.mark.timeout(20)
@pytest.mark.parametrize("kind", ["fifo", "dev-zero", "junk-10mb", "directory"])
def test_what_is_not_a_small_regular_file_is_never_read(
    kind: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A FIFO, a device or a directory is not even opened (a FIFO's open would wait for a
    writer); a file over the limit is opened but not read past its size."""
    _skip_unless_here(kind)
    path = HOSTILE[kind](tmp_path / "rig.toml")
    files_opened: list[str] = []
    real_open = os.open

    def watching_open(file: object, *args: object, **kwargs: object) -> int:
        files_opened.append(os.fsdecode(file))  # type: ignore[arg-type]
        return real_open(file, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "open", watching_open)
    with pytest.raises(ConfigError, match=r"too large|not a regular file") as caught:
        read_toml(path)
    assert str(caught.value).startswith(f"{path}: ")
    assert files_opened == ([str(path)] if kind == "junk-10mb" else [])
    assert main(["run", "--config", str(path)]) == 2
    _one_line_naming(capsys, path)


def _config_with(tmp_path: pathlib.Path, old: str, new: str) -> pathlib.Path:
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path / "runs"}"')
    assert old in text
    path = tmp_path / "rig.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.timeout(20)
@pytest.mark.parametrize("kind", ["junk", "utf16", "fifo", "deep", "huge", "directory"])
def test_hostile_device_profile(
    kind: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    _skip_unless_here(kind)
    profile = HOSTILE[kind](tmp_path / "drive.toml")
    config = _config_with(tmp_path, 'preset = "dc-servo"', f'device = "{profile}"')
    assert main(["run", "--config", str(config), "--emulate"]) == 2
    line = _one_line_naming(capsys, profile)
    assert str(config) in line and "[emulator] device" in line
    assert not opened


@pytest.mark.timeout(20)
@pytest.mark.parametrize("kind", ["junk", "utf16", "fifo", "dev-zero", "directory"])
def test_hostile_eds_is_refused_before_the_bus_opens(
    kind: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], opened: list[str]
) -> None:
    _skip_unless_here(kind)
    eds = pathlib.Path("/dev/zero") if kind == "dev-zero" else HOSTILE[kind](tmp_path / "drive.eds")
    config = _config_with(tmp_path, "latency = 0.0", f'latency = 0.0\neds = "{eds}"\n')
    config.write_text(config.read_text().replace("[run]", "[run]\nperiod = 0.001", 1))
    assert main(["run", "--config", str(config)]) == 2  # a real bus: not opened
    line = _one_line_naming(capsys, config)
    assert "'motor' eds" in line and (kind == "dev-zero" or str(eds) in line)
    assert not opened


def test_a_huge_eds_is_refused(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    eds = tmp_path / "drive.eds"
    with eds.open("wb") as f:
        f.truncate(9 << 20)  # sparse: 9 MiB that cost nothing, over the 8 MiB of an EDS
    config = _config_with(tmp_path, "latency = 0.0", f'latency = 0.0\neds = "{eds}"\n')
    assert main(["run", "--config", str(config), "--emulate"]) == 2
    assert "9.0 MiB: too large (EDS/DCF file: at most 8 MiB)" in _one_line_naming(capsys, eds)


@pytest.mark.timeout(20)
@pytest.mark.parametrize(
    ("name", "kind"), [("config.json", "fifo"), ("config.json", "deep"), ("samples.csv", "junk")]
)
def test_hostile_run_directory(
    name: str, kind: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _skip_unless_here(kind)
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"resolved_period": 0.001}))
    (run / "samples.csv").write_text("command,measurement\n0,0\n")
    (run / name).unlink()
    hostile = (_deep_json if kind == "deep" else HOSTILE[kind])(run / name)
    assert main(["identify", "--from-log", str(run)]) == 2
    _one_line_naming(capsys, hostile)


@pytest.mark.timeout(20)
@pytest.mark.parametrize("kind", ["fifo", "deep", "junk", "not-a-number"])
def test_hostile_identify_result(
    kind: str, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _skip_unless_here(kind)
    path = tmp_path / "model.json"
    if kind == "not-a-number":
        path.write_text(json.dumps({"a_m": "16", "b_m": 680.0}))
    else:
        path = (_deep_json if kind == "deep" else HOSTILE[kind])(path)
    argv = ["design", "dtsm", "--from-identify", str(path), "--period", "1e-3", "--lam", "-15"]
    assert main(argv) == 2
    line = _one_line_naming(capsys, path)
    if kind == "not-a-number":
        assert "a_m = '16'" in line


def test_only_what_a_file_may_hold_is_read(tmp_path: pathlib.Path) -> None:
    """Strings and comments do not nest; a UTF-8 BOM is fine; dotted keys nest too; the limit is
    the size of a configuration."""
    ok = tmp_path / "ok.toml"
    ok.write_bytes(b"\xef\xbb\xbf" + ('a = "' + "[" * 100 + '" # ' + "{" * 100 + "\nb = [[1]]\n").encode())
    assert read_toml(ok) == {"a": "[" * 100, "b": [[1]]}
    dotted = tmp_path / "dotted.toml"
    dotted.write_text(".".join(["k"] * (MAX_DEPTH + 2)) + " = 1\n")
    with pytest.raises(ConfigError, match=r"dotted\.toml: k\.k\.k.*nested deeper than 32 levels"):
        read_toml(dotted)
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 40 + "]" * 40)
    with pytest.raises(ConfigError, match=r"deep\.json: line 1: .*nested deeper"):
        read_json(deep)
    limit = tmp_path / "limit.toml"
    limit.write_text("#" * (CONFIG_LIMIT - 1) + "\n")
    assert read_toml(limit) == {}
    limit.write_text("#" * CONFIG_LIMIT + "\n")
    with pytest.raises(ConfigError, match=r"too large \(TOML file: at most 1 MiB\)"):
        read_toml(limit)
