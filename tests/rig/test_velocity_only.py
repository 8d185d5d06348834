"""Drives without a position 0x6064 (speed and torque controllers: the Sevcon dictionaries of
``tests/drivers/dictionaries``), through the command line with no EDS of their own: a jog reports
its result from 0x606C in the drive's own rpm, and ``rig run`` drives them in PV without a
position factor."""

from __future__ import annotations

import json
import math
import pathlib
from collections.abc import Iterator

import pytest

from rig.cli import main
from tests.drivers.foreign import ForeignDrive

RPM = 60.0 / (2.0 * math.pi)  #: rpm per rad/s

RUN = """[run]
duration = 0.2
period = 0.01
time = "lockstep"
output = "{out}"

[bus]
interface = "virtual"
channel = "{channel}"

[[axis]]
name = "motor"
kind = "cia402"
node_id = 1
mode = "pv"

[axis.limits]
command = 50.0
speed = 60.0
current = 30.0

[controller]
kind = "speed-reference"
reads = ["motor"]
commands = ["motor"]

[reference]
kind = "step"
value = 20.0
start = 0.0
"""


@pytest.fixture
def drive(request: pytest.FixtureRequest, tmp_path: pathlib.Path) -> Iterator[ForeignDrive]:
    d = ForeignDrive(request.param, tmp_path)
    yield d
    d.close()


@pytest.mark.parametrize("drive", ["sevcon-gen4", "sevcon-nano", "sevcon-espac"], indirect=True)
def test_a_jog_without_a_position_reports_the_speed_in_the_drive_s_own_rpm(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        [
            "drive",
            "--interface",
            "virtual",
            "--channel",
            drive.channel,
            "--json",
            "jog",
            "5",
            "--for",
            "0.2",
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    r = json.loads(out)
    assert r["result"] == "done" and r["stop_confirmed"] is True and "position_rad" not in r
    assert r["reached_rad_s"] == pytest.approx(round(5 * RPM) / RPM, rel=1e-9)  # 48 rpm, read back
    assert (0x60FF, 0, round(5 * RPM), None) in drive.fake.downloads  # 5 rad/s = 48 rpm
    assert [u for u in drive.fake.uploads if u[0] == 0x6064] == [(0x6064, 0, 0x06020000)]  # asked once


@pytest.mark.parametrize("drive", ["sevcon-gen4", "sevcon-nano", "sevcon-espac"], indirect=True)
def test_a_run_in_profile_velocity_needs_no_position_factor(
    drive: ForeignDrive, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "rig.toml"
    cfg.write_text(RUN.format(out=tmp_path / "runs", channel=drive.channel))
    code = main(["run", "--config", str(cfg), "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    summary = json.loads(out)
    assert summary["safe_stop_reason"] is None and summary["stop_confirmed"] is True
    assert summary["axes"]["motor"]["max_abs_velocity"] == pytest.approx(round(20 * RPM) / RPM, rel=1e-9)
    targets = {v for i, _s, v in drive.fake.rpdo_writes if i == 0x60FF}
    assert round(20 * RPM) in targets  # 20 rad/s = 191 rpm in the RPDO
