"""The dual-axis twin: two motors behind one CANopen node, each axis a CiA 402 logical device of its
own (axis 2's objects 0x800 above axis 1's), driven here by canopen's ``RemoteNode`` (a client the
toolkit did not write) by the objects' own indices, in lock-step."""

from __future__ import annotations

from collections.abc import Iterator

import canopen
import pytest

from drivers.maps.cia import Controlword, EmcyCode, Mode, PowerState, decode_statusword, map_entry
from plant_emulator.device_profile import device_profile
from plant_emulator.lockstep import LockstepBench
from plant_emulator.multi_axis import MultiAxisDrive

PROFILE = device_profile("dual-axis")
AXIS_2 = 0x800


@pytest.fixture
def bench() -> Iterator[LockstepBench]:
    b = LockstepBench(PROFILE.physics, device=PROFILE)
    yield b
    b.close()


def _node(b: LockstepBench) -> canopen.RemoteNode:
    node = canopen.RemoteNode(1, str(PROFILE.eds))
    b.host.add_node(node)
    return node


def map_rpdo(node: canopen.RemoteNode, number: int, cob_id: int, entries: list[tuple[int, int, int]]) -> None:
    """RPDO ``number`` (its default transmission type) on ``cob_id`` mapping ``entries`` ((index, sub,
    bits)), written by SDO as CiA 301 orders it: invalid, emptied, mapped, counted, valid."""
    comm, mapping = 0x1400 + number - 1, 0x1600 + number - 1
    node.sdo[comm][1].raw = 0x80000000 | cob_id
    node.sdo[mapping][0].raw = 0
    for sub, (index, subindex, bits) in enumerate(entries, 1):
        node.sdo[mapping][sub].raw = map_entry(index, subindex, bits)
    node.sdo[mapping][0].raw = len(entries)
    node.sdo[comm][1].raw = cob_id


def _state(node: canopen.RemoteNode, offset: int) -> PowerState | None:
    return decode_statusword(node.sdo[0x6041 + offset].raw)


def _enable(node: canopen.RemoteNode, offset: int, mode: Mode, b: LockstepBench) -> None:
    node.sdo[0x6060 + offset].raw = int(mode)
    for word in (Controlword.SHUTDOWN, Controlword.SWITCH_ON, Controlword.ENABLE_OPERATION):
        node.sdo[0x6040 + offset].raw = int(word)
    b.sync()
    assert _state(node, offset) is PowerState.OPERATION_ENABLED


def _rad_s(node: canopen.RemoteNode, offset: int) -> float:
    """0x606C of an axis in rad/s (4096 increments per revolution, velocity in increments/s)."""
    return float(node.sdo[0x606C + offset].raw) * 2.0 * 3.141592653589793 / 4096


def test_one_node_says_it_is_a_module_of_two_cia402_drives(bench: LockstepBench) -> None:
    node = _node(bench)
    assert node.sdo[0x1000].raw == 0xFFFF0192  # additional information FFFFh: several devices, 402 first
    assert node.sdo[0x67FF].raw == node.sdo[0x6FFF].raw == 0x00020192  # each axis: a servo drive
    drive = bench.devices[0]
    assert isinstance(drive, MultiAxisDrive) and len(drive.drives) == 2
    assert drive.drives[0].axis is not drive.drives[1].axis  # two motors
    assert drive.shafts[0] is not drive.shafts[1]


def test_each_axis_runs_by_its_own_objects_and_the_other_stays_as_it_is(bench: LockstepBench) -> None:
    node = _node(bench)
    _enable(node, AXIS_2, Mode.CSV, bench)
    node.sdo[0x68FF].raw = round(-15.0 * 4096 / (2 * 3.141592653589793))  # axis 2: -15 rad/s
    for _ in range(1500):
        bench.sync()
    assert _rad_s(node, AXIS_2) == pytest.approx(-15.0, abs=0.05)
    assert _state(node, 0) is PowerState.SWITCH_ON_DISABLED  # axis 1 untouched, at rest
    assert node.sdo[0x606C].raw == 0
    _enable(node, 0, Mode.CSV, bench)
    node.sdo[0x60FF].raw = round(8.0 * 4096 / (2 * 3.141592653589793))
    for _ in range(1500):
        bench.sync()
    assert _rad_s(node, 0) == pytest.approx(8.0, abs=0.05)
    assert _rad_s(node, AXIS_2) == pytest.approx(-15.0, abs=0.05)
    assert node.sdo[0x6061].raw == node.sdo[0x6861].raw == int(Mode.CSV)


def test_an_rpdo_of_axis_2_s_objects_commands_axis_2_only(bench: LockstepBench) -> None:
    """RPDO3 (axis 2's share) mapped with 0x6840 and 0x68FF, synchronous: its target acts at the
    next SYNC on axis 2's motor; axis 1's target is not touched by it."""
    node = _node(bench)
    _enable(node, AXIS_2, Mode.CSV, bench)
    _enable(node, 0, Mode.CSV, bench)
    map_rpdo(node, 3, 0x401, [(0x6840, 0, 16), (0x68FF, 0, 32)])
    node.nmt.state = "OPERATIONAL"
    target = round(12.0 * 4096 / (2 * 3.141592653589793))
    for _ in range(1500):
        bench.host.send_message(
            0x401,
            int(Controlword.ENABLE_OPERATION).to_bytes(2, "little")
            + target.to_bytes(4, "little", signed=True),
        )
        bench.sync()
    assert node.sdo[0x68FF].raw == target
    assert _rad_s(node, AXIS_2) == pytest.approx(12.0, abs=0.05)
    assert node.sdo[0x60FF].raw == 0 and abs(_rad_s(node, 0)) < 0.05


def test_a_fault_of_one_axis_is_that_axis_s(bench: LockstepBench) -> None:
    """Axis 2 over its speed limit (0x6880): axis 2 in FAULT with 0x683F = 0x8400, an EMCY from
    the node; axis 1 turns on, OPERATION ENABLED, its 0x603F clear."""
    node = _node(bench)
    emcys: list[int] = []
    node.emcy.add_callback(lambda err: emcys.append(err.code))
    node.nmt.state = "OPERATIONAL"
    _enable(node, 0, Mode.CSV, bench)
    _enable(node, AXIS_2, Mode.CSV, bench)
    node.sdo[0x6880].raw = 100  # rpm: axis 2's limit
    speed = round(20.0 * 4096 / (2 * 3.141592653589793))
    node.sdo[0x60FF].raw = speed
    node.sdo[0x68FF].raw = speed
    for _ in range(1500):
        bench.sync()
    assert _state(node, AXIS_2) is PowerState.FAULT and node.sdo[0x683F].raw == EmcyCode.OVER_SPEED
    assert emcys == [EmcyCode.OVER_SPEED]
    assert _state(node, 0) is PowerState.OPERATION_ENABLED and node.sdo[0x603F].raw == 0
    assert _rad_s(node, 0) == pytest.approx(20.0, abs=0.05)


def test_a_lost_host_has_each_axis_react_by_its_own_0x6007(bench: LockstepBench) -> None:
    """The node's heartbeat consumer loses the host: axis 1 (0x6007 = 2, disable voltage) coasts
    at once, axis 2 (0x6807 = 3, quick stop) brakes along its ramp."""
    node = _node(bench)
    node.nmt.state = "OPERATIONAL"
    node.sdo[0x1016][1].raw = 0x7F << 16 | 50  # host node 127, 50 ms
    node.sdo[0x6007].raw = 2
    node.sdo[0x6807].raw = 3
    node.sdo[0x685A].raw = 6  # quick stop ramp, staying in QUICK STOP ACTIVE
    for offset in (0, AXIS_2):
        _enable(node, offset, Mode.CSV, bench)
        node.sdo[0x60FF + offset].raw = round(10.0 * 4096 / (2 * 3.141592653589793))
    for _ in range(500):
        bench.host.send_message(0x77F, b"\x05")  # the host's heartbeat, every SYNC
        bench.sync()
    for _ in range(200):  # the host is gone: 80 ms
        bench.sync()
    assert _state(node, 0) is PowerState.SWITCH_ON_DISABLED
    assert _state(node, AXIS_2) is PowerState.QUICK_STOP_ACTIVE
