"""``rig drive move`` on a drive met without its EDS (issue 33 items 1 and 2): the toolkit's generic
dictionary has no profile velocity 0x6081 (its own drive has no profile position), so what the
device has decides. The independent fake device of ``tests/drivers/fake_device.py`` serves the
Nanotec C5-E's dictionary (0x6081 = 1000 rpm, above the default --max-speed) on python-can's
virtual bus; ``rig drive`` runs in this process without ``--eds``."""

from __future__ import annotations

import pathlib
from collections.abc import Iterator

import pytest

from drivers.canopen_axis import CanopenAxis
from rig.cli import main
from tests.drivers.foreign import ForeignDrive

RPM_PER_RAD_S = 30.0 / 3.141592653589793


@pytest.fixture
def drive(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[ForeignDrive]:
    # rig drive's own axis: a thread answers its SDO, so generous under load, never waited out
    # (0.3 s was waited out once in CI's default run: 'no SDO answer (SDO upload, 0x1018:03)')
    monkeypatch.setattr(CanopenAxis, "SDO_TIMEOUT", 2.0)
    d = ForeignDrive("nanotec-c5e", tmp_path)
    yield d
    d.close()


def _rig(d: ForeignDrive, *argv: str) -> list[str]:
    return ["drive", "--interface", "virtual", "--channel", d.channel, *argv]  # no --eds


def _profile_writes(d: ForeignDrive) -> list[tuple[int, int, int | None]]:
    """The SDO downloads to 0x6081/0x6083/0x6084: (index, value, abort or None)."""
    return [(i, v, abort) for i, _, v, abort in d.fake.downloads if i in (0x6081, 0x6083, 0x6084)]


def test_a_move_without_an_eds_writes_its_speed_by_the_standards_type(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    """The drive's own 0x6081 (1000 rpm) is read from it and is above --max-speed 20 rad/s, so the
    limit is written to it in rpm (191) as CiA 402's UNSIGNED32, and the move arrives; --speed
    and --accel likewise. Before: refused with 'abort 0x06090011' that no device sent."""
    assert main(_rig(drive, "move", "1")) == 0, capsys.readouterr().err
    assert _profile_writes(drive) == [(0x6081, round(20.0 * RPM_PER_RAD_S), None)]
    drive.fake.downloads.clear()
    assert main(_rig(drive, "move", "0", "--speed", "5", "--accel", "50")) == 0, capsys.readouterr().err
    assert _profile_writes(drive) == [
        (0x6081, round(5.0 * RPM_PER_RAD_S), None),
        (0x6083, round(50.0 * RPM_PER_RAD_S), None),
        (0x6084, round(50.0 * RPM_PER_RAD_S), None),
    ]


def test_a_device_without_a_profile_velocity_is_refused_before_the_move(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    """A device without 0x6081: without --speed the move's speed is unknown, refused in one line
    naming node, object and what to give, before anything is sent; with --speed the device's
    abort is that line, before the enable (no controlword, no target)."""
    del drive.fake.od.entries[(0x6081, 0)]
    assert main(_rig(drive, "move", "1")) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "node 1: the drive's profile velocity 0x6081:00 (the move's speed) cannot be read" in err
    assert "nothing was sent; give --speed RAD_S, or the drive's own EDS (--eds FILE)" in err
    assert drive.fake.downloads == [] and drive.fake.nmt_log == []
    assert main(_rig(drive, "move", "1", "--speed", "5")) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "node 1: 0x6081:00 refused 48 (the move's speed): abort 0x06020000" in err, err
    assert "give the drive's own EDS (--eds FILE)" in err
    assert [(i, abort) for i, _, _, abort in drive.fake.downloads] == [(0x6081, 0x06020000)]
    assert drive.fake.nmt_log == []


def test_sdo_write_without_an_eds_names_what_it_cannot_send(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    """``sdo write`` of 0x6081 goes to the device by CiA 402's type; an object the generic EDS lacks
    that is none of a move's profile values (0x609A) is one line, exit 2, nothing sent (was: exit 1
    on an abort code no device sent)."""
    assert main(_rig(drive, "sdo", "write", "0x6081", "100")) == 0, capsys.readouterr().err
    assert _profile_writes(drive) == [(0x6081, 100, None)]
    drive.fake.downloads.clear()
    assert main(_rig(drive, "sdo", "write", "0x609A", "1")) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rig drive sdo write: 0x609A:00 is not in ") and len(err.splitlines()) == 1
    assert err.endswith("nothing was sent; give the drive's own EDS (--eds FILE)")
    assert drive.fake.downloads == []


def test_home_without_an_eds_writes_its_method_by_the_standards_type(
    drive: ForeignDrive, capsys: pytest.CaptureFixture[str]
) -> None:
    """The generic EDS has no homing method 0x6098 (the toolkit's own drive does not home): met
    without its EDS, ``home --method`` writes it as CiA 402's INTEGER8 and the device decides;
    ``sdo read 0x6098`` shows its value by that type, not raw bytes. Before: home refused with
    '... lacks 0x6098 (Homing method), which rig drive home needs'."""
    assert main(_rig(drive, "sdo", "read", "0x6098")) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "(INTEGER8 (CiA))" in lines[0]  # not in the EDS in use: by the standard's type
    assert lines[1].split()[1:] == [str(drive.fake.od.entries[(0x6098, 0)].value), "(0x23)"]
    assert main(_rig(drive, "home", "--method", "-3")) == 0, capsys.readouterr().err
    writes = [(i, v, abort) for i, _, v, abort in drive.fake.downloads if i == 0x6098]
    assert writes == [(0x6098, -3, None)]
    assert "homing" in capsys.readouterr().out
