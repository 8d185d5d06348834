"""``rig lss``: CiA 305 through canopen's LSS master against the emulator's LSS slaves, in lock-step
(``--emulate``: a twin fresh from the box, node-ID 255), and its refusals in one line."""

from __future__ import annotations

import argparse
import json
from typing import Any

import pytest

from plant_emulator.device_profile import device_profile
from plant_emulator.lockstep import LockstepBench
from rig.cli import main
from rig.cli.lss import _act
from rig.commission.lss import LssTool

EPOS4 = "0x000000FB:0x65520000:0x00010000:0x00000001"  #: the epos4 twin's LSS address


def _json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    assert main(["lss", "--emulate", "epos4", "--json", *argv]) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)  # type: ignore[no-any-return]


def test_scan_finds_the_drive_without_a_node_id(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, "scan")
    assert out["unconfigured"] == 1 and out["node_id"] == 255 and out["select"] == EPOS4
    assert out["found"] == {
        "vendor": "0x000000FB",
        "product": "0x65520000",
        "revision": "0x00010000",
        "serial": "0x00000001",
    }


def test_a_fresh_drive_gets_a_node_id_and_boots_with_it(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, "--fastscan", "node-id", "5", "--store")
    assert out["selected_by"] == f"fastscan {EPOS4}" and out["vendor"] == "0x000000FB"
    assert (out["node_id_was"], out["node_id"], out["stored"], out["booted"]) == (255, 5, True, True)
    out = _json(capsys, "--select", EPOS4, "inquire")
    assert out["selected_by"] == f"switch state selective {EPOS4}" and out["node_id"] == 255
    out = _json(capsys, "bitrate", "500", "--store")
    assert (
        out["bitrate_kbit"] == 500 and out["stored"] and out["selected_by"].startswith("switch state global")
    )
    out = _json(capsys, "bitrate", "1000", "--activate", "10")
    assert out["activated_after_ms"] == 10


def test_a_configured_drive_takes_its_node_id_at_reset_communication() -> None:
    """rig lss's own steps on the toolkit's drive at node 1: node-ID 9 is pending until --reset."""
    bench = LockstepBench("dc-servo", device=device_profile("drive-rig"))
    try:
        tool = LssTool(bench.host, timeout=0.01)
        args = argparse.Namespace(
            action="node-id", node_id=9, store=False, reset=False, stop=False, fastscan=False
        )
        toolkit = "0x00000DB1:0x00000402:0x00010000:0x00000001"
        from rig.commission.lss import Address

        out = _act(tool, args, Address.parse(toolkit))
        assert (out["node_id_was"], out["node_id"], out["booted"]) == (1, 9, None)
        assert bench.devices[0].node_id == 1  # pending
        out = _act(tool, argparse.Namespace(**{**vars(args), "reset": True}), Address.parse(toolkit))
        assert out["node_id_was"] == 1 and out["booted"] is True and bench.devices[0].node_id == 9
    finally:
        bench.close()


def test_two_slaves_answering_one_inquiry_are_refused_as_such() -> None:
    """The dc-servo preset's drive and encoder both speak LSS: switch state global puts both in
    the configuration state, and an inquiry gets two answers."""
    bench = LockstepBench("dc-servo")
    try:
        assert [d.lss is not None for d in bench.devices] == [True, True]
        tool = LssTool(bench.host, timeout=0.01)
        tool.all_slaves()
        with pytest.raises(Exception, match="more than one LSS slave answered; with more than one LSS slave"):
            tool.inquire()
    finally:
        bench.close()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--select", "0xFB:0x65520000:0x10000:2", "inquire"],
            "LSS: no slave has the address 0x000000FB:0x65520000",
        ),
        (
            ["bitrate", "10", "--store"],
            "configure bit timing 10 kbit/s: the slave answered bit rate not supported",
        ),
        (["inquire"], None),
    ],
)
def test_what_the_slave_refuses_is_one_line_and_exit_1(
    argv: list[str], message: str | None, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["lss", "--emulate", "epos4", *argv])
    err = capsys.readouterr().err
    if message is None:
        assert code == 0, err
        return
    assert code == 1 and message in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["node-id", "0"], "rig lss node-id: 0: a node-ID is 1..127 (or 255: none)"),
        (
            ["bitrate", "300"],
            "300 kbit/s is not in CiA 305's bit timing table (1000, 800, 500, 250, 125, 50, 20",
        ),
        (["--select", "0xFB:1:2", "inquire"], "--select: '0xFB:1:2' is not VENDOR:PRODUCT:REVISION:SERIAL"),
        (["--fastscan", "scan"], "rig lss scan: it selects nobody"),
        (["--timeout", "0", "scan"], "--timeout: must be in (0, 10] s"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2_before_the_bus_opens(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    opened: list[str] = []
    monkeypatch.setattr("rig.cli.lss.open_network", lambda *a: opened.append("bus"))
    assert main(["lss", "--interface", "socketcand", "--channel", "can0", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and opened == []


def test_a_twin_without_lss_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lss", "--emulate", "nanotec-c5e", "scan"]) == 2
    assert "its EDS says LSS_Supported=0: that drive has no LSS" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("dc-servo", "a preset's drives have their node-IDs; give a zoo twin"),
        ("epos5", "neither a preset (dc-servo, "),
    ],
)
def test_emulate_names_a_zoo_twin_as_every_command_s_emulate_does(
    name: str, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--emulate NAME`` (one spelling on every command): a preset is refused in one line, its
    drives have node-IDs; a name that is neither is told what there is."""
    assert main(["lss", "--emulate", name, "inquire"]) == 2
    err = capsys.readouterr().err
    assert said in err and len(err.strip().splitlines()) == 1, err
