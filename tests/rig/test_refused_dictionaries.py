"""A dictionary (EDS/DCF) that lies, refused in one line naming the file, the object and the value,
with no traceback and a non-zero exit, before the drive is written (issue 33, inputs that lie).

Across processes: the independent fake device behind its own socketcand server
(``tests.rig.test_foreign_processes.Served``) and ``rig drive``, ``rig run`` and ``rig emulate`` in
processes of their own. In this process, with python-can's virtual bus, the cases that differ only
in which object or which command. What each task needs is ``drivers.maps.cia402_needs``'s table.
"""

from __future__ import annotations

import pathlib
import subprocess
import sys
from collections.abc import Iterator

import pytest

from drivers.maps import CIA402_EDS
from rig.cli import main
from tests.drivers.eds_edit import with_value, without
from tests.drivers.foreign import ForeignDrive
from tests.rig.test_foreign_processes import CONFIG, Served


def write(folder: pathlib.Path, name: str, text: str) -> str:
    path = folder / name
    path.write_text(text)
    return str(path)


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def served(tmp_path: pathlib.Path) -> Iterator[Served]:
    s = Served("maxon-epos4", tmp_path)
    yield s
    if s.proc.returncode is None:
        s.proc.kill()
        s.proc.communicate(timeout=10)


def test_a_drive_met_with_a_dictionary_that_lies_is_refused_across_processes(
    served: Served, tmp_path: pathlib.Path
) -> None:
    """Issue 33's probes, against a device in another process: an EDS without the statusword (was:
    ValueError traceback), one whose 0x1800:02 is declared 4 bytes where the drive answers 1 (was:
    canopen's ObjectDictionaryError traceback), and a CSP run on an EDS without 0x6064. Nothing is
    written to the drive."""
    text = pathlib.Path(served.eds).read_text()
    no_status = write(tmp_path, "no-statusword.eds", without(text, 0x6041))
    status = served.rig("drive", *served.bus(), "--eds", no_status, "status")
    assert status.returncode == 2
    assert one_line(status.stderr) == (
        f"rig: {no_status}: lacks 0x6041 (Statusword), which rig drive status needs (CiA 402): give the "
        "drive's own EDS/DCF, which declares them"
    )

    wide = write(tmp_path, "wide.eds", with_value(text, "1800sub2", "DataType", "0x0007"))
    status = served.rig("drive", *served.bus(), "--eds", wide, "status")
    assert status.returncode == 2
    assert one_line(status.stderr) == (
        f"rig: node 1: 0x1800:02 (Transmission type) is UNSIGNED32 (4 bytes) in {wide}, but the device "
        "answered 1 byte (ff): the EDS/DCF is not this device's; give the device's own"
    )

    no_position = write(tmp_path, "no-position.eds", without(text, 0x6064))
    cfg = tmp_path / "rig.toml"
    cfg.write_text(CONFIG.format(out=tmp_path / "runs", port=served.port, eds=no_position))
    run = served.rig("run", "--config", str(cfg))
    assert run.returncode == 2
    line = one_line(run.stderr)
    assert line.startswith(f"rig: {cfg}: [[axis]] 'motor' eds: {no_position}: lacks 0x6064 (Position actual")
    assert line.endswith("which mode csp needs (CiA 402): give the drive's own EDS/DCF, which declares them")
    log = served.log()
    assert log["downloads"] == [] and log["nmt"] == [] and log["rpdos"] == []


def rig_emulate(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "rig.cli", "emulate", *argv, "--port", "0"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def test_rig_emulate_refuses_a_dictionary_that_lies_in_one_line(tmp_path: pathlib.Path) -> None:
    """Was: SdoAbortedError's traceback at boot (no 0x6040/0x6041), and a drive that aborted every
    read of 0x6085 (its DefaultValue unreadable)."""
    text = pathlib.Path(CIA402_EDS).read_text()
    no_control = write(tmp_path, "no-control.eds", without(text, 0x6040, 0x6041))
    done = rig_emulate("--eds", no_control)
    assert done.returncode == 2 and done.stdout == ""
    line = one_line(done.stderr)
    assert line.startswith(f"rig: {no_control}: lacks 0x6040 (Controlword), 0x6041 (Statusword), which ")
    banana = write(tmp_path, "banana.eds", with_value(text, "6085", "DefaultValue", "$NODEID+banana"))
    done = rig_emulate("--eds", banana)
    assert done.returncode == 2 and done.stdout == ""
    assert one_line(done.stderr) == (
        f"rig: {banana}: object 0x6085:00 (Quick stop deceleration): DefaultValue=$NODEID+banana: 'banana' "
        "is not a number (decimal, 0x hexadecimal or 0 octal); correct the value in the file (CiA 306)"
    )


@pytest.fixture
def drive(tmp_path: pathlib.Path) -> Iterator[ForeignDrive]:
    d = ForeignDrive("maxon-epos4", tmp_path)
    yield d
    d.close()


@pytest.mark.parametrize(
    ("action", "lacks", "said"),
    [
        (["enable"], (0x6040,), "0x6040 (Controlword), which rig drive enable needs"),
        (["jog", "1", "--for", "0.1"], (0x60FF,), "0x60FF (Target velocity), which rig drive jog needs"),
        (["move", "0.5"], (0x607A,), "0x607A (Target position), which rig drive move needs"),
        (["jog", "1", "--for", "0.1"], (0x6060, 0x6061), "0x6060 (Modes of operation), 0x6061 (Modes of"),
        (["home"], (0x6098,), "0x6098 (Homing method), which rig drive home needs"),
    ],
)
def test_rig_drive_refuses_what_the_action_needs_and_the_dictionary_lacks(
    *,
    drive: ForeignDrive,
    tmp_path: pathlib.Path,
    capsys: pytest.CaptureFixture[str],
    action: list[str],
    lacks: tuple[int, ...],
    said: str,
) -> None:
    eds = write(tmp_path, "lacking.eds", without(pathlib.Path(drive.eds).read_text(), *lacks))
    assert main(["drive", "--interface", "virtual", "--channel", drive.channel, "--eds", eds, *action]) == 2
    line = one_line(capsys.readouterr().err)
    assert line.startswith(f"rig: {eds}: lacks ") and said in line
    assert drive.fake.downloads == [] and drive.fake.nmt_log == []


@pytest.mark.parametrize("command", ["drive", "run"])
def test_an_unreadable_default_value_is_refused_by_rig_drive_and_rig_run(
    drive: ForeignDrive, tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    eds = write(
        tmp_path,
        "banana.eds",
        with_value(pathlib.Path(drive.eds).read_text(), "6060", "DefaultValue", "0x1+x"),
    )
    if command == "drive":
        argv = ["drive", "--interface", "virtual", "--channel", drive.channel, "--eds", eds, "status"]
    else:
        cfg = tmp_path / "rig.toml"
        cfg.write_text(CONFIG.format(out=tmp_path / "runs", port=1, eds=eds))
        argv = ["run", "--config", str(cfg)]
    assert main(argv) == 2
    line = one_line(capsys.readouterr().err)
    assert f"{eds}: object 0x6060:00 (Modes of operation): DefaultValue=0x1+x: 'x' is not a number" in line
    assert drive.fake.uploads == [] and drive.fake.downloads == []
