"""The cross-process scenarios of ``rig faults`` (``rig.faults.wire``): the EPOS4 twin in ``rig
emulate`` and ``rig run`` in processes of their own, real time over socketcand. Each ends with
the motor at rest 1 s after the fault and the operator told what happened, without a
traceback. Wall-clock runs, so in the ``timing`` tier (``.ci/run`` runs it)."""

from __future__ import annotations

import pytest

from rig.faults.suite import run_faults
from rig.faults.wire import PERIOD, WIRE_SCENARIOS

#: the whole suite of scenarios runs in the first test's set-up: 19 scenarios, each a host and an
#: emulator process, over 120 s on a loaded PC
pytestmark = [pytest.mark.timing, pytest.mark.timeout(900)]

Row = dict[str, object]


@pytest.fixture(scope="module")
def table() -> dict[str, Row]:
    return {row["scenario"]: row for row in run_faults(list(WIRE_SCENARIOS))}


@pytest.mark.parametrize("name", list(WIRE_SCENARIOS))
def test_no_traceback_and_the_motor_at_rest(table: dict[str, Row], name: str) -> None:
    row = table[name]
    assert "Traceback" not in str(row["message"]), row
    if name == "emulator-sigkill":  # the drive is gone with its process
        assert row["motor_speed_after_1s"] is None and row["drive_disabled"] is None, row
    else:
        assert abs(row["motor_speed_after_1s"]) < 0.1 and row["drive_disabled"] is True, row  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("name", "words", "confirmed"),
    [
        ("emulator-sigkill", "the bus is lost", False),
        ("emulator-sigstop", "node 1: no TPDO for", True),
        ("link-drop", "Broken pipe", False),
        ("host-sigterm", "SIGTERM (terminate)", True),
        ("host-sigkill", "the drive's EMCY: 0x8130", False),
        ("client-never-reads", "completed without a stop", True),
        ("disk-full", "StorageError", True),
        ("disk-full", "not written whole: trace.asc", True),  # cut short, at a whole line
        ("read-only", "not written whole: samples.mat, plot.png, summary.json (exit code 6)", True),
    ],
)
def test_what_the_operator_is_told(table: dict[str, Row], name: str, words: str, confirmed: bool) -> None:
    row = table[name]
    assert words in str(row["message"]) and row["stop_confirmed"] is confirmed, row


def test_a_stop_keeps_every_sample(table: dict[str, Row]) -> None:
    scenarios = ("emulator-sigkill", "emulator-sigstop", "link-drop", "host-sigterm", "client-never-reads")
    for name in (*scenarios, "disk-full", "read-only"):
        assert table[name]["samples_lost"] == 0, table[name]


def test_a_killed_host_loses_at_most_100_ms(table: dict[str, Row]) -> None:
    lost = table["host-sigkill"]["samples_lost"]
    assert isinstance(lost, int) and lost * PERIOD <= 0.1, table["host-sigkill"]
