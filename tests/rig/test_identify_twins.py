"""rig identify on the zoo's twins in CST: a commercial drive's own PDOs and units, a torque in per
mille of its 0x6076; J, B and T_c of the twin's physics; a twin that cannot take a torque is
refused, naming why."""

from __future__ import annotations

import json
import re

import pytest

from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.device_profile import device_profile
from plant_emulator.presets import preset_params
from rig.cli import main

#: the twins whose 0x6502 has CST and whose 0x6076 gives the torque's unit
CST = ["drive-rig", "epos4", "faulhaber-mc5004", "kollmorgen-s300", "nanotec-c5e"]


@pytest.mark.parametrize("device", CST)
def test_inertia_and_friction_of_each_twin(device: str, capsys: pytest.CaptureFixture[str]) -> None:
    profile = device_profile(device)
    p = preset_params(profile.physics, profile.params)
    truth = DCMotorParams.from_am_bm(a_m=p.a_m, b_m=p.b_m, r_r=p.r_r, b=p.friction)
    # 3 s of the friction experiment (the default is 10 s): what differs between the twins is their
    # PDOs, units and resolution, which a shorter run crosses as well (J, B, T_c within 0.25 % here)
    assert main(["identify", "--emulate", device, "--input", "torque", "--duration", "3", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    f = doc["friction"]
    assert doc["input"] == "torque" and doc["excitation"] == "friction" and f["separable"], f
    assert f["inertia"] == pytest.approx(truth.j, rel=0.02)
    assert f["viscous"] == pytest.approx(truth.b, rel=0.02)
    assert f["coulomb"] == pytest.approx(p.coulomb, rel=0.02)


@pytest.mark.parametrize(
    "device,why",
    [
        ("erl-pcs", r"mode cst is not in 0x6502"),
        ("tmcm-1160", r"mode cst is not in 0x6502"),
        ("compact-2pdo", r"mode CST needs 0x6076, which the drive does not give"),
    ],
)
def test_a_twin_without_a_torque_mode_is_refused(
    device: str, why: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["identify", "--emulate", device, "--input", "torque"]) == 2
    assert re.search(why, capsys.readouterr().err)


def test_a_twin_takes_no_voltage(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["identify", "--emulate", "epos4"]) == 2
    assert "a commercial drive's twin takes a torque (CST): give --input torque" in capsys.readouterr().err
    assert main(["identify", "--emulate", "no-such-drive", "--input", "torque"]) == 2
    assert "rig emulate --list" in capsys.readouterr().err
