"""``rig drive store`` / ``restore`` (0x1010 / 0x1011 sub 1): confirmed, then written, on the zoo's
twins in lock-step; refused in one line, before anything is written, where nobody can confirm, where
the dictionary or the drive says it keeps nothing on command, or where a reset would drop a
drive's torque."""

from __future__ import annotations

import argparse
import io
import json
from collections.abc import Iterator
from typing import Any

import pytest

from rig.cli import drive_dictionary, main
from rig.cli.drive import _tool

VELOCITY = 0x6081  #: profile velocity (955 rpm by the epos4 twin's EDS)


class Terminal(io.StringIO):
    """A terminal's stdin with the person's answers in it."""

    def isatty(self) -> bool:
        return True


def _args(action: str, **kw: Any) -> argparse.Namespace:
    base = dict(
        action=action, emulate="epos4", eds=None, node=1, axis=1, units=[], json=False, yes=True, reset=False
    )
    return argparse.Namespace(**(base | kw))


@pytest.fixture
def epos4() -> Iterator[Any]:
    """rig drive's own tool on an in-process epos4 twin, and the twin's node as canopen sees it."""
    tool, close = _tool(_args("store"))
    try:
        yield tool, tool.axis.node  # canopen's RemoteNode of the axis: its SDO client, its NMT master
    finally:
        close()


def _reset(node: Any) -> None:
    node.nmt.state = "RESET"  # the boot-up comes within the send (lock-step)


def test_store_keeps_a_value_over_a_reset_and_restore_reset_brings_the_default_back(epos4: Any) -> None:
    tool, node = epos4
    node.sdo[VELOCITY].raw = 500
    out = drive_dictionary.act(tool, _args("store"))
    assert out["object"] == "0x1010:01" and out["written"] == "save" and "maxon motor ag" in out["identity"]
    node.sdo[VELOCITY].raw = 700
    _reset(node)
    assert node.sdo[VELOCITY].raw == 500
    out = drive_dictionary.act(tool, _args("restore"))
    assert out["reset"] is False and node.sdo[VELOCITY].raw == 500  # not yet in force
    lines = drive_dictionary.result_lines(out)
    assert any("in force after node 1's next reset" in line for line in lines)
    out = drive_dictionary.act(tool, _args("restore", reset=True))
    assert out["reset"] is True and node.sdo[VELOCITY].raw == 955
    assert node.nmt.state == "PRE-OPERATIONAL"


def test_the_person_at_the_terminal_is_asked_and_no_writes_nothing(
    epos4: Any, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    tool, node = epos4
    node.sdo[VELOCITY].raw = 500
    monkeypatch.setattr("sys.stdin", Terminal("n\n"))
    with pytest.raises(Exception, match="rig drive store: not confirmed; nothing was written"):
        drive_dictionary.act(tool, _args("store", yes=False))
    asked = capsys.readouterr().err
    assert asked.startswith("Node 1 (vendor 0x000000FB (maxon motor ag) / product 0x65520000")
    assert asked.endswith("(0x1010:01 = 'save')? [y/N] ")
    _reset(node)
    assert node.sdo[VELOCITY].raw == 955  # not stored
    node.sdo[VELOCITY].raw = 500
    monkeypatch.setattr("sys.stdin", Terminal("yes\n"))
    drive_dictionary.act(tool, _args("store", yes=False))
    _reset(node)
    assert node.sdo[VELOCITY].raw == 500


def test_restore_reset_is_refused_while_the_drive_is_enabled(epos4: Any) -> None:
    tool, _ = epos4
    tool.enable()
    with pytest.raises(Exception, match="is OPERATION ENABLED: a reset node drops its torque; disable it"):
        drive_dictionary.act(tool, _args("restore", reset=True))
    assert tool.axis.read_power_state().value == "OPERATION ENABLED"  # nothing was written or reset
    tool.disable()


@pytest.mark.parametrize(
    ("argv", "stdin", "message"),
    [
        (["--json", "store"], None, "rig drive store: --json without --yes: a program confirms with --yes"),
        (["restore"], io.StringIO("y\n"), "rig drive restore: no terminal to confirm on: give --yes"),
    ],
)
def test_nobody_to_confirm_is_refused_before_the_bus_opens(
    argv: list[str],
    stdin: Any,
    message: str,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    opened: list[str] = []
    monkeypatch.setattr("rig.cli.drive.open_network", lambda *a: opened.append("bus"))
    if stdin is not None:
        monkeypatch.setattr("sys.stdin", stdin)
    assert main(["drive", "--interface", "socketcand", "--channel", "can0", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert opened == []  # no bus was opened


def test_a_drive_that_keeps_nothing_on_command_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["drive", "--emulate", "compact-2pdo", "--json", "store", "--yes"]) == 2
    err = capsys.readouterr().err
    assert "compact-2pdo.eds has no 0x1010:01: the drive does not store its parameters on command" in err


def test_the_json_says_what_was_written(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["drive", "--emulate", "epos4", "--json", "restore", "--yes", "--reset"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["object"] == "0x1011:01" and out["written"] == "load" and out["reset"] is True
