"""``rig drive``: commissioning one drive, on an in-process zoo twin (``--emulate``)."""

from __future__ import annotations

import json

import pytest

from rig.cli import main


def _json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:  # type: ignore[type-arg]
    assert main(["drive", "--emulate", "nanotec-c5e", "--json", *argv]) == 0
    return json.loads(capsys.readouterr().out)  # type: ignore[no-any-return]


def test_status_says_what_the_drive_is(capsys: pytest.CaptureFixture[str]) -> None:
    s = _json(capsys, "status")
    assert s["identity"]["vendor"] == "0x0000026C" and s["state"] == "SWITCH ON DISABLED"
    assert "switch on disabled" in s["statusword_bits"]
    assert s["units"]["from"]["position"] == "0x60A8" and s["units"]["from"]["velocity"] == "0x60A9"
    assert s["error_code"].startswith("0x603F = 0x0000")
    assert set(s["pdo_mapping"]) == {f"{k}PDO{n}" for k in "RT" for n in (1, 2, 3, 4)}
    assert "CST" in s["supported_modes"] and s["last_emcy"] is None


def test_jog_move_and_home_end_at_rest_by_the_drive_s_own_stop(capsys: pytest.CaptureFixture[str]) -> None:
    r = _json(capsys, "jog", "10", "--for", "0.5")
    assert r["result"] == "done" and r["stop_confirmed"] is True and r["state"] == "SWITCH ON DISABLED"
    assert r["still_turning"] == {}  # the shaft at rest for its hold after the disable
    assert r["position_rad"] == pytest.approx(5.0, abs=0.3)  # 10 rad/s for 0.5 s, ramps included
    r = _json(capsys, "move", "3")
    assert r["position_rad"] == pytest.approx(3.0, abs=0.01) and r["velocity_rad_s"] == 0.0
    r = _json(capsys, "home", "--method", "37")
    assert r["result"] == "done" and r["position_rad"] == 0.0


def test_sdo_by_index_and_by_name(capsys: pytest.CaptureFixture[str]) -> None:
    assert _json(capsys, "sdo", "read", "0x60A9")["value"] == 0x00B44700
    assert _json(capsys, "sdo", "read", "Identity object.Vendor-ID")["value"] == 0x26C
    assert _json(capsys, "sdo", "write", "0x6081", "500")["written"] == 500


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["jog", "50", "--for", "1"], "jog speed 50 rad/s exceeds --max-speed 20 rad/s"),
        (["move", "50"], "a move of 50 rad exceeds --max-travel 10 rad"),
        (["move", "1", "--speed", "25"], "--speed 25 rad/s: must be in (0, --max-speed 20] rad/s"),
        (["move", "1", "--hold", "-1"], "argument --hold: must be > 0, got -1"),
        (["sdo", "read", "No such thing"], "neither index[:sub] nor a name in the EDS"),
        (["--node", "200", "status"], "--node: must be 1..127"),
        (["jog", "1", "--for", "0"], "--for: must be in (0, 60] s"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(
    capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    pre = [a for a in argv if a.startswith("--node")] + ([argv[1]] if argv[0] == "--node" else [])
    rest = argv[2:] if argv[0] == "--node" else argv
    assert main(["drive", "--emulate", "epos4", *pre, *rest]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
