"""``rig drive`` and ``rig run`` on the first day with somebody else's drive: the independent fake
device of ``tests/drivers/fake_device.py`` serving the dictionaries of ``tests/drivers/dictionaries``
on python-can's virtual bus, driven through the command line as a lab engineer would."""

from __future__ import annotations

import json
import pathlib
from collections.abc import Iterator

import pytest

from drivers.canopen_axis import CanopenAxis
from rig.cli import main
from tests.drivers.foreign import DICTIONARIES, ForeignDrive

#: the --json keys of ``rig drive status`` that scripts read
STATUS_KEYS = {
    "node", "identity", "state", "statusword", "statusword_bits", "mode", "supported_modes",
    "error_code", "last_emcy", "units", "pdo_mapping",
}  # fmt: skip


@pytest.fixture
def drive(
    request: pytest.FixtureRequest, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> Iterator[ForeignDrive]:
    # rig drive's own axis: a thread answers its SDO, so generous under load, never waited out
    # (0.3 s was waited out under load: 'no SDO answer 0x1018:02'); a test of an absent node sets less
    monkeypatch.setattr(CanopenAxis, "SDO_TIMEOUT", 2.0)
    d = ForeignDrive(request.param, tmp_path)
    yield d
    d.close()


def _rig(d: ForeignDrive, *argv: str) -> list[str]:
    return ["drive", "--interface", "virtual", "--channel", d.channel, "--eds", d.eds, *argv]


@pytest.mark.parametrize("drive", DICTIONARIES, indirect=True)
def test_status_works_on_every_drive_and_writes_nothing(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    """A status moves nothing and needs no factor: where the drive gives none, its own units."""
    assert main(_rig(drive, "--json", "status")) == 0
    s = json.loads(capsys.readouterr().out)
    assert STATUS_KEYS <= set(s)
    assert s["identity"]["vendor"] == f"0x{drive.dictionary.device['vendor']:08X}"
    no_factor = s["units"]["position_units_per_rad"] is None
    assert ("--units counts_per_rev=N gives rad" in s["units"]["position_unit"]) == no_factor
    assert drive.fake.downloads == [] and drive.fake.nmt_log == [] and drive.fake.rpdos == []


@pytest.mark.parametrize("drive", ["technosoft-ipos"], indirect=True)
def test_status_text_is_a_report_for_a_person(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(_rig(drive, "status")) == 0
    out = capsys.readouterr().out
    lines = {line[:15].strip(): line[16:] for line in out.splitlines()}
    assert lines["state"].startswith("SWITCH ON DISABLED (statusword 0x0")
    assert lines["mode"] == "no mode (0x6061 = 0)"
    assert lines["identity"] == (
        "vendor 0x000001A3 (Technosoft) / product 0x01BAE7AE / revision 0x00000001 / serial 0x00C0FFEE"
    )
    assert (
        "manufacturer" not in lines["modes offered"]
        and "cyclic synchronous torque (cst)" in lines["modes offered"]
    )
    assert lines["position unit"].startswith("the drive's increments")
    assert lines["last EMCY"] == "none since the drive was reached"
    assert "\nPDO mapping in force:\n  PDO    COB-ID  valid  type  entries\n" in out
    rpdo1 = next(line for line in out.splitlines() if line.startswith("  RPDO1"))
    assert rpdo1.split()[:4] == ["RPDO1", "0x201", "yes", "255"]
    assert rpdo1.endswith("0x6040:00 Controlword (16 bit), 0x607A:00 Target position (32 bit)")


@pytest.mark.parametrize("drive", ["maxon-epos2"], indirect=True)
def test_an_action_that_needs_a_factor_names_the_units_option(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(_rig(drive, "move", "1")) == 2
    err = capsys.readouterr().err.strip()
    assert "gives no position resolution (0x608F, 0x60A8, 0x6092); set --units counts_per_rev=VALUE" in err
    assert len(err.splitlines()) == 1 and drive.fake.downloads == []


@pytest.mark.parametrize("drive", ["faulhaber-mc5004"], indirect=True)
def test_a_move_says_where_it_stopped_and_whether_that_is_its_window(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    """The drive says target reached 10 increments short: within its position window (0x6067 =
    10), a normal arrival; 15 short, outside it: stopped short, and why."""
    per_rad = 4096 / (2 * 3.141592653589793)
    drive.fake.pp_short_by = 10
    assert main(_rig(drive, "--json", "move", "1")) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["result"] == "done" and r["target_rad"] == 1.0 and r["stopped_short"] is None
    assert r["error_rad"] == pytest.approx(1.0 - (round(per_rad) - 10) / per_rad) and r["error_units"] == 10
    assert r["error_said"] == "within the drive's position window (0x6067 = 10, 0.01534 rad)"
    drive.fake.pp_short_by = 15
    assert main(_rig(drive, "--json", "move", "0")) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["stopped_short"].startswith("stopped 0.02301 rad (15 position units) short of 0 rad")
    assert "outside its position window (0x6067 = 10)" in r["stopped_short"]


@pytest.mark.parametrize("drive", ["faulhaber-mc5004"], indirect=True)
def test_a_wrong_node_id_suggests_rig_scan_on_the_same_bus(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(CanopenAxis, "SDO_TIMEOUT", 0.3)  # no node 5: the wait is waited out
    assert main(_rig(drive, "--node", "5", "status")) == 1
    err = capsys.readouterr().err.strip()
    assert "node 5: no SDO answer to 0x1000" in err
    assert f"`rig scan --interface virtual --channel {drive.channel}` lists the nodes that answer" in err
    assert len(err.splitlines()) == 1


def test_a_run_without_a_period_names_the_emulators(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    cfg = tmp_path / "c.toml"
    cfg.write_text(example.read_text())
    assert main(["run", "--config", str(cfg)]) == 2
    err = capsys.readouterr().err
    assert "[run] period must be set" in err and "--emulate" in err and "`rig emulate`" in err


@pytest.mark.parametrize("drive", ["faulhaber-mc5004"], indirect=True)
def test_a_run_that_reaches_no_device_leaves_no_run_directory(
    drive: ForeignDrive,
    tmp_path: pathlib.Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(CanopenAxis, "SDO_TIMEOUT", 0.3)  # no node 9: the wait is waited out
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    text = example.read_text().replace('output = "runs"', f'output = "{tmp_path / "runs"}"')
    text = text.replace("[run]", "[run]\nperiod = 0.001", 1).replace("node_id = 1", "node_id = 9")
    text = text.replace('interface = "socketcand"', 'interface = "virtual"').replace(
        'channel = "can0"', f'channel = "{drive.channel}"'
    )
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    assert main(["run", "--config", str(cfg)]) == 1
    err = capsys.readouterr().err
    assert (
        "node 9: no SDO answer to 0x1000" in err
        and f"rig scan --interface virtual --channel {drive.channel}" in err
    )
    assert not (tmp_path / "runs").exists()


def test_the_summary_says_its_peaks_are_maxima() -> None:
    from rig.report.summary import summary_lines

    summary = {
        "cycles": 10, "overruns": 0, "rms_error": 0.1, "max_error": 0.2, "error_unit": "rad",
        "chattering_amplitude": float("nan"), "safe_stop_reason": None, "stop_confirmed": True,
        "run_dir": "r", "command_units": {"motor": "V"},
        "axes": {"motor": {"max_abs_velocity": 120.4, "max_abs_current": 23.76, "max_abs_command": 5.0}},
    }  # fmt: skip
    axis = next(line for line in summary_lines(summary) if line.startswith("axis motor"))
    assert axis.endswith("max |velocity| 120.4 rad/s, max |current| 23.76 A, max |command| 5 V")


@pytest.mark.parametrize("drive", ["beckhoff-ax8000"], indirect=True)
@pytest.mark.parametrize(
    ("action", "mode"),
    [
        (["jog", "1", "--for", "0.1"], "profile velocity (pv)"),
        (["move", "1"], "profile position (pp)"),
        (["home"], "homing"),
    ],
)
def test_a_profile_mode_the_drive_lacks_is_refused_before_anything_is_sent(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str], action: list[str], mode: str
) -> None:
    """A drive with the cyclic modes only (0x6502 = 0x780): jog, move and home are refused naming
    the modes it offers, before an NMT command or a write."""
    assert main(_rig(drive, "--units", "counts_per_rev=4096", *action)) == 2
    err = capsys.readouterr().err.strip()
    assert f"rig drive {action[0]} runs the drive in {mode}, which it does not offer" in err
    assert "cyclic synchronous torque with commutation angle (cstca)" in err and "nothing was sent" in err
    assert drive.fake.nmt_log == [] and drive.fake.downloads == [] and len(err.splitlines()) == 1


@pytest.mark.parametrize("drive", ["roboteq-sbl"], indirect=True)
def test_status_gives_a_velocity_in_rpm_without_increments(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(_rig(drive, "status")) == 0
    lines = {line[:15].strip(): line[16:] for line in capsys.readouterr().out.splitlines()}
    assert lines["velocity unit"] == "9.5493 drive units per rad/s (from 0x60A9)"
    assert lines["position unit"].startswith("the drive's increments")
    assert "velocity (vl)" in lines["modes offered"] and "profile torque (tq)" in lines["modes offered"]


@pytest.mark.parametrize("drive", ["maxon-epos4"], indirect=True)
def test_jog_and_enable_write_no_position_target(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    """A jog runs in profile velocity: 0x60FF is held at 0 before the enable, and 0x607A, which that
    mode does not use, is not written; a bare enable in the drive's own mode (0x6061 = 0) writes
    no target at all."""
    assert main(_rig(drive, "jog", "1", "--for", "0.1")) == 0
    writes = [(w[0], w[2]) for w in drive.fake.downloads]
    assert 0x607A not in {w[0] for w in writes}
    assert writes.index((0x60FF, 0)) < writes.index((0x6040, 15)) < writes.index((0x60FF, 10))
    drive.fake.downloads.clear()
    drive.fake.od.entries[(0x6061, 0)].value = 0
    assert main(_rig(drive, "enable")) == 0
    assert [w[0] for w in drive.fake.downloads] == [0x6040, 0x6040, 0x6040]


@pytest.mark.parametrize("drive", ["technosoft-ipos", "maxon-epos2"], indirect=True)
def test_a_run_refused_at_discovery_sends_the_drive_nothing(
    drive: ForeignDrive, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """rig run with mode = "voltage" on a drive that is not the toolkit's (and a mode the EPOS2
    lacks) is refused from what was read: not even the controlword of the close is sent."""
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
    text = example.read_text().replace('output = "runs"', f'output = "{tmp_path / "runs"}"')
    text = text.replace("[run]", "[run]\nperiod = 0.001", 1)
    text = text.replace('interface = "socketcand"', 'interface = "virtual"').replace(
        'channel = "can0"', f'channel = "{drive.channel}"'
    )
    text = text.replace('mode = "voltage"', f'mode = "voltage"\neds = "{drive.eds}"')
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    assert main(["run", "--config", str(cfg)]) == 2
    assert "is a manufacturer mode of drive-rig's own drive" in capsys.readouterr().err
    assert drive.fake.downloads == [] and drive.fake.nmt_log == [] and drive.fake.rpdos == []


@pytest.mark.parametrize("drive", ["nanotec-c5e"], indirect=True)
@pytest.mark.parametrize(
    "action", [["enable"], ["disable"], ["reset"], ["sdo", "write", "0x6081", "100"]], ids=lambda a: a[0]
)
def test_a_write_with_another_devices_eds_is_refused_before_it_is_sent(
    drive: ForeignDrive, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], action: list[str]
) -> None:
    """Identity before any write beyond reading: enable, disable, reset and sdo write with the EDS of
    another device (the EPOS4's against a Nanotec C5-E) are refused in one line naming both
    identities, and the drive gets no NMT command and no write (found from outside: rig drive --eds
    of another product's EDS enabled the drive, exit 0)."""
    from tests.drivers.fake_device import Dictionary

    other = str(Dictionary.load("maxon-epos4").write_eds(tmp_path))
    bus = ["drive", "--interface", "virtual", "--channel", drive.channel, "--eds", other]
    assert main([*bus, *action]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "give the device's own EDS/DCF" in err, err
    assert "is vendor 0x0000026C" in err and "describes vendor 0x000000FB" in err
    assert drive.fake.downloads == [] and drive.fake.nmt_log == [] and drive.fake.rpdos == []
