"""``rig drive dump``: every object of a drive's dictionary read from the drive, in lock-step on the
zoo's twins (``--emulate``), and the DCF it writes read back by the toolkit's loader and canopen's."""

from __future__ import annotations

import argparse
import json
import math
import pathlib

import canopen
import pytest

from drivers.cia402 import Cia402Axis
from drivers.errors import ConfigError
from drivers.maps.eds_values import variables
from drivers.maps.od import load_od
from plant_emulator.device_profile import device_profile
from plant_emulator.lockstep import LockstepBench
from rig.cli import drive_dictionary, main
from rig.commission.drive import DriveTool
from tests.drivers.eds_edit import with_value

EPOS4 = device_profile("epos4")


def _dump(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:  # type: ignore[type-arg]
    """``rig drive --emulate epos4 --json dump ARGV``'s document."""
    assert main(["drive", "--emulate", "epos4", "--json", "dump", *argv]) == 0
    return json.loads(capsys.readouterr().out)  # type: ignore[no-any-return]


def test_every_object_of_the_eds_is_read_with_its_value_type_unit_and_si(
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = _dump(capsys)
    od = load_od(EPOS4.eds, 1)
    named = sorted((v.index, v.subindex) for v in variables(od))
    rows = {r["object"]: r for r in out["objects"]}
    assert sorted(tuple(int(p, 16) for p in key.split(":")) for key in rows) == named
    assert out["read"] == len(named) and out["not_read"] == 0 and not out["standard_only"]
    vendor = rows["0x1018:01"]
    assert (vendor["value"], vendor["hex"], vendor["type"]) == (0xFB, "0x000000FB", "UNSIGNED32")
    assert vendor["access"] == "ro"
    assert rows["0x1008:00"]["value"] == "EPOS4 twin"
    low = rows["0x607D:01"]  # a negative INTEGER32: decimal, and its two's complement in hex
    assert (low["value"], low["hex"]) == (-(2**31), "0x80000000")
    assert low["quantity"]["unit"] == "rad" and low["quantity"]["drive_unit"].startswith("position units")
    speed = rows["0x6081:00"]  # 100 rad/s in the twin's rpm (the EDS's default), and back in SI
    assert speed["value"] == round(100.0 * 60.0 / (2.0 * math.pi))
    held = speed["quantity"]
    assert held["unit"] == "rad/s" and held["value"] == pytest.approx(100.0, rel=1e-3)
    assert rows["0x6075:00"]["quantity"]["value"] == 10.0  # 10000 mA
    assert rows["0x1018:00"]["quantity"] is None and rows["0x607D:00"]["quantity"] is None  # counts


def test_objects_the_drive_refuses_are_listed_with_the_abort_in_words(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A dictionary naming an object the drive lacks, a write-only one and one whose declared
    type is shorter than the drive's answer: each listed as not read and why, exit code 0."""
    text = pathlib.Path(EPOS4.eds).read_text()
    text = with_value(with_value(text, "607Dsub1", "DataType", "0x0003"), "607Dsub1", "DefaultValue", "0")
    text += (
        "\n[6086]\nParameterName=Motion profile type\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\n"
        "DefaultValue=0\nPDOMapping=0\n"
        "\n[2002]\nParameterName=Password\nObjectType=0x7\nDataType=0x0007\nAccessType=wo\n"
        "DefaultValue=0\nPDOMapping=0\n"
    )
    eds = tmp_path / "epos4-more.eds"
    eds.write_text(text)
    assert main(["drive", "--emulate", "epos4", "--eds", str(eds), "dump"]) == 0
    lines = {line[:9]: line for line in capsys.readouterr().out.splitlines()}
    assert "SDO abort 0x06020000: object does not exist in the object dictionary" in lines["0x6086:00"]
    assert "Motion profile type" in lines["0x6086:00"] and "(not read)" in lines["0x6086:00"]
    assert "write-only: not read" in lines["0x2002:00"]
    assert "not its type's size: answered 4 bytes (00 00 00 80)" in lines["0x607D:01"]
    assert "0x000003BB = 955" in lines["0x6081:00"]  # the rest read as before


def test_without_its_own_eds_a_foreign_drive_is_read_for_the_standard_objects_only() -> None:
    """The toolkit's generic dictionary against the Nanotec twin: nothing of 0x2000-0x5FFF (the
    toolkit drive's, not this one's) is read; the generic objects the twin lacks are refused; a
    DCF is refused before anything is read."""
    profile = device_profile("nanotec-c5e")
    bench = LockstepBench(profile.physics, device=profile)
    axis = Cia402Axis("drive", bench.host, 1, mode="csp", eds=None)
    try:
        tool = DriveTool(axis, idle=bench.sync, period=bench.period)
        args = argparse.Namespace(action="dump", dcf=str(pathlib.Path("never.dcf")), emulate=None)
        with pytest.raises(ConfigError, match="a DCF is the drive's own EDS with its values; give it"):
            drive_dictionary.act(tool, args)
        assert not pathlib.Path("never.dcf").exists()
        out = drive_dictionary.act(tool, argparse.Namespace(action="dump", dcf=None, emulate=None))
    finally:
        axis._forget()
        bench.close()
    rows = {r["object"]: r for r in out["objects"]}
    assert out["standard_only"] and all(not 0x2000 <= int(k[2:6], 16) < 0x6000 for k in rows)
    assert rows["0x1018:01"]["value"] == 0x26C  # the device's own identity
    refused = [k for k, r in rows.items() if r["refused"]]
    assert refused and all("0x06020000" in rows[k]["refused"] for k in refused)
    assert "0x100A:00" in refused  # software version: in the generic dictionary, not in the twin


def test_the_dcf_holds_the_values_read_and_both_loaders_read_it_back(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dcf = tmp_path / "epos4-node1.dcf"
    out = _dump(capsys, "--dcf", str(dcf))
    assert out["dcf"] == str(dcf)
    read = {r["object"]: r["value"] for r in out["objects"] if r["refused"] is None}
    ours = load_od(dcf, 1)
    theirs = canopen.import_od(str(dcf))  # node id from [DeviceComissioning]
    assert theirs.node_id == 1
    for od in (ours, theirs):
        for var in variables(od):
            key = f"0x{var.index:04X}:{var.subindex:02X}"
            assert var.value == read[key], (key, var.value, read[key])
    text = dcf.read_text()
    assert "LastEDS=epos4.eds" in text and "FileName=epos4-node1.dcf" in text
    assert "[DeviceComissioning]\nNodeID=1\nNodeName=EPOS4 twin\n" in text
    assert "LSS_SerialNumber=1" in text
    # the DCF as the dictionary of the next dump: its values replaced, not doubled
    again = tmp_path / "again.dcf"
    assert main(["drive", "--emulate", "epos4", "--eds", str(dcf), "dump", "--dcf", str(again)]) == 0
    capsys.readouterr()
    assert again.read_text().count("ParameterValue=") == text.count("ParameterValue=") == len(read)
