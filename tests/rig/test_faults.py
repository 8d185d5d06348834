"""The fault suite in lock-step: every injected fault is detected in time, the drive ends disabled
and at rest, no sample is lost (the cross-process scenarios: test_faults_across_processes)."""

from __future__ import annotations

import json

import pytest

from rig.cli import main
from rig.faults.suite import LOCKSTEP, run_faults


@pytest.fixture(scope="module")
def table() -> dict[str, dict[str, object]]:
    return {row["scenario"]: row for row in run_faults(LOCKSTEP)}


@pytest.mark.parametrize("name", LOCKSTEP)
def test_the_motor_is_at_rest_1_s_after_the_fault(table, name: str) -> None:  # type: ignore[no-untyped-def]
    """A drive that resets (NMT reset node) comes back in SWITCH ON DISABLED with its power stage
    off and its motor coasts, as a real one does (the host does not re-enable a drive that reset
    under it), to rest on its friction (the servo's ~13 rad/s at 32 rad/s^2 of Coulomb friction);
    the others brake along their ramps."""
    row = table[name]
    assert abs(row["motor_speed_after_1s"]) < 0.1, row
    if name == "node-reset":
        assert row["drive_disabled"], row
        return
    assert row["stop_confirmed"] is not name.startswith("modbus-"), row  # a dead line confirms nothing


@pytest.mark.parametrize("name", [n for n in LOCKSTEP if n not in ("frame-loss-1%", "heartbeat-loss")])
def test_detected_within_three_cycles_and_disabled(table, name: str) -> None:  # type: ignore[no-untyped-def]
    row = table[name]
    limit = 200 if name == "frame-loss-10%" else 3  # frame loss: whenever 3 TPDOs in a row are missing
    assert row["detected_after_cycles"] is not None and 0 <= row["detected_after_cycles"] <= limit, row
    assert row["drive_disabled"] is True, row
    assert row["samples_lost"] == 0, row


def test_messages_name_the_fault_and_the_device(table) -> None:  # type: ignore[no-untyped-def]
    expected = {
        "tpdo-stall": "node 1: no TPDO",
        "heartbeat-loss": "node 1: heartbeat lost",
        "node-reset": "node 1: NMT state",
        "over-current-emcy": "node 1: EMCY 0x2310",
        "encoder-glitch": "node 1: position jumped",
        "controller-nan": "controller output is nan",
        "limit-violation": "node 1: speed",
        "ctrl-c": "Ctrl-C",
        "modbus-timeout": "no answer reading status_word, actual_speed (registers 3-4)",
        "modbus-exception": "unit 1, register 3, exception code 4",
    }
    for name, text in expected.items():
        assert text in table[name]["message"], table[name]


def test_heartbeat_loss_within_the_configured_timeout(table) -> None:  # type: ignore[no-untyped-def]
    row = table["heartbeat-loss"]  # heartbeat every 100 ms, timeout 150 ms: detected by 0.25 s = 625 cycles
    assert 0 < row["detected_after_cycles"] <= 625 and row["drive_disabled"] and row["samples_lost"] == 0


def test_one_percent_frame_loss_is_ridden_through(table) -> None:  # type: ignore[no-untyped-def]
    row = table["frame-loss-1%"]
    assert row["detected_after_cycles"] is None and row["drive_disabled"] and row["samples_lost"] == 0


def test_modbus_drive_trips_on_communication_loss(table) -> None:  # type: ignore[no-untyped-def]
    assert "drive tripped 0x6681" in table["modbus-timeout"]["message"]


def test_faults_json_contract(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["faults", "--json", "--scenario", "encoder-glitch", "--scenario", "ctrl-c"]) == 0
    rows = json.loads(capsys.readouterr().out)
    keys = {
        "scenario",
        "detected_after_cycles",
        "drive_disabled",
        "samples_lost",
        "message",
        "motor_speed_after_1s",
        "stop_confirmed",
    }
    assert [r["scenario"] for r in rows] == ["encoder-glitch", "ctrl-c"] and all(keys <= set(r) for r in rows)
    assert main(["faults", "--scenario", "meteor"]) == 2
