"""The emulated drives store their parameters and restore their defaults as CiA 301 has it (0x1010,
0x1011, ``plant_emulator.param_store``), seen from canopen's SDO client and NMT master in lock-step:
a value written and not stored is gone after a reset, one stored survives resets, a restore puts
the defaults back at the next reset and not before, a wrong signature is refused."""

from __future__ import annotations

import dataclasses
import pathlib
from collections.abc import Iterator
from typing import Any

import canopen
import pytest
from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
from plant_emulator.device_profile import device_profile
from plant_emulator.lockstep import LockstepBench
from tests.drivers.eds_edit import with_value

SAVE, LOAD = b"save", b"load"  #: 0x65766173 and 0x64616F6C written as UNSIGNED32
VELOCITY = 0x6081  #: profile velocity: a parameter (0x3BB = 955 rpm, the EDS's default)


def _twin(profile: Any) -> Iterator[tuple[LockstepBench, Any]]:
    bench = LockstepBench(profile.physics, device=profile)
    node = canopen.RemoteNode(1, str(profile.eds))
    bench.host.add_node(node)
    try:
        yield bench, node
    finally:
        bench.close()


@pytest.fixture
def twin() -> Iterator[tuple[LockstepBench, Any]]:
    yield from _twin(device_profile("epos4"))


def _reset(node: Any, what: str = "RESET") -> None:
    node.nmt.state = what  # the boot-up comes within the send (lock-step)
    assert node.nmt.state == "PRE-OPERATIONAL"


def test_reads_say_it_stores_on_command_and_a_wrong_signature_is_refused(twin: Any) -> None:
    _, node = twin
    assert node.sdo[0x1010][1].raw == 1 and node.sdo[0x1011][1].raw == 1
    for index, data in ((0x1010, LOAD), (0x1011, SAVE), (0x1010, b"SAVE")):
        with pytest.raises(SdoAbortedError) as refused:
            node.sdo.download(index, 1, data)
        assert refused.value.code == cia.SdoAbortCode.STORE_FAILED == 0x08000020
    node.sdo[VELOCITY].raw = 500
    _reset(node)
    assert node.sdo[VELOCITY].raw == 955  # nothing was stored


def test_stored_parameters_survive_resets_and_defaults_come_back_at_the_reset_after_a_restore(
    twin: Any,
) -> None:
    _, node = twin
    node.sdo[VELOCITY].raw = 500
    node.sdo[0x1800][5].raw = 40  # TPDO1 event timer: a communication parameter
    node.sdo[0x607A].raw = 12345  # a target: the command of the moment, never stored
    node.sdo.download(0x1010, 1, SAVE)
    assert node.sdo[0x1010][1].raw == 1  # the signature is a command, not a value kept
    node.sdo[VELOCITY].raw = 700  # after the store: not stored
    _reset(node)
    assert (node.sdo[VELOCITY].raw, node.sdo[0x1800][5].raw, node.sdo[0x607A].raw) == (500, 40, 0)
    _reset(node, "RESET COMMUNICATION")
    assert node.sdo[0x1800][5].raw == 40
    node.sdo.download(0x1011, 1, LOAD)
    assert node.sdo[VELOCITY].raw == 500  # in force at the next reset, not before
    _reset(node)
    assert (node.sdo[VELOCITY].raw, node.sdo[0x1800][5].raw) == (955, 0)
    node.sdo[VELOCITY].raw = 600
    _reset(node)
    assert node.sdo[VELOCITY].raw == 955  # the defaults are what is stored now


def test_a_store_of_one_area_keeps_the_other_as_it_was(tmp_path: pathlib.Path) -> None:
    """An EDS whose 0x1010 has sub 2 (communication) and 3 (application), as many drives' do."""
    text = (pathlib.Path(device_profile("epos4").eds)).read_text()
    extra = "".join(
        f"\n[1010sub{sub}]\nParameterName=Save {what} parameters\nObjectType=0x7\nDataType=0x0007\n"
        "AccessType=rw\nDefaultValue=0x00000001\nPDOMapping=0\n"
        for sub, what in ((2, "communication"), (3, "application"))
    )
    text = with_value(with_value(text, "1010", "SubNumber", "4"), "1010sub0", "DefaultValue", "3")
    eds = tmp_path / "epos4-areas.eds"
    eds.write_text(text + extra)
    profile = dataclasses.replace(device_profile("epos4"), eds=eds)
    for twin in _twin(profile):
        _, node = twin
        node.sdo[VELOCITY].raw = 500
        node.sdo[0x1800][5].raw = 40
        node.sdo.download(0x1010, 2, SAVE)  # the communication area only
        _reset(node)
        assert (node.sdo[VELOCITY].raw, node.sdo[0x1800][5].raw) == (955, 40)
        node.sdo[VELOCITY].raw = 500
        node.sdo.download(0x1010, 3, SAVE)  # the application area
        node.sdo.download(0x1011, 2, LOAD)
        _reset(node)
        assert (node.sdo[VELOCITY].raw, node.sdo[0x1800][5].raw) == (500, 0)
