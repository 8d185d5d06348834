"""Conformance of the emulated CANopen devices, with canopen's RemoteNode as the peer."""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator

import canopen
import pytest
from canopen.sdo import SdoAbortedError

from drivers.maps import CIA402_EDS, CIA406_EDS
from drivers.maps.cia import PowerState
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.induction_motor import ImParams
from plant_emulator.lockstep import LockstepBench

S = PowerState

#: statusword bits 0-6 (mask, value) of each state, from the CiA 402 table: written out here
#: rather than taken from drivers.maps.cia, so a misreading there cannot pass
_STATUSWORD = [
    (0x4F, 0x00, S.NOT_READY_TO_SWITCH_ON),
    (0x4F, 0x40, S.SWITCH_ON_DISABLED),
    (0x6F, 0x21, S.READY_TO_SWITCH_ON),
    (0x6F, 0x23, S.SWITCHED_ON),
    (0x6F, 0x27, S.OPERATION_ENABLED),
    (0x6F, 0x07, S.QUICK_STOP_ACTIVE),
    (0x4F, 0x0F, S.FAULT_REACTION_ACTIVE),
    (0x4F, 0x08, S.FAULT),
]


def statusword_state(word: int) -> PowerState:
    """The state statusword ``word`` reports."""
    states = [state for mask, value, state in _STATUSWORD if word & mask == value]
    assert len(states) == 1, hex(word)
    return states[0]


@pytest.fixture
def rig() -> Iterator[tuple[LockstepBench, canopen.RemoteNode, list[tuple[int, bytes]]]]:
    bench = LockstepBench("dc-servo")
    frames: list[tuple[int, bytes]] = []
    bench.host.bus.listeners.append(lambda m: frames.append((m.arbitration_id, bytes(m.data))))
    node = canopen.RemoteNode(1, CIA402_EDS)
    bench.host.add_node(node)
    yield bench, node, frames
    bench.close()


def _drive(bench: LockstepBench) -> EmulatedDrive:
    d = bench.devices[0]
    assert isinstance(d, EmulatedDrive)
    return d


def _cw(node: canopen.RemoteNode, bench: LockstepBench, cw: int) -> PowerState:
    node.sdo[0x6040].raw = cw
    return statusword_state(node.sdo[0x6041].raw)


def test_boot_up_heartbeat_and_identity(rig) -> None:  # type: ignore[no-untyped-def]
    bench, node, frames = rig
    assert node.sdo[0x1000].raw == 0x00020192
    assert node.sdo[0x1018][2].raw == 0x402
    for _ in range(501):  # 100 ms heartbeat, 0.4 ms period: beats at 0.1 s and 0.2 s
        bench.sync()
    beats = [d for cob, d in frames if cob == 0x701]
    assert beats == [b"\x7f", b"\x7f"]  # pre-operational, every 100 ms of emulated time


def test_every_power_state_transition(rig) -> None:  # type: ignore[no-untyped-def]
    bench, node, _ = rig
    assert statusword_state(node.sdo[0x6041].raw) is S.SWITCH_ON_DISABLED  # 0, 1
    steps = [
        (0x06, S.READY_TO_SWITCH_ON),  # 2
        (0x07, S.SWITCHED_ON),  # 3
        (0x0F, S.OPERATION_ENABLED),  # 4
        (0x07, S.SWITCHED_ON),  # 5
        (0x06, S.READY_TO_SWITCH_ON),  # 6
        (0x00, S.SWITCH_ON_DISABLED),  # 7
        (0x06, S.READY_TO_SWITCH_ON),
        (0x0F, S.OPERATION_ENABLED),  # 3 + 4
        (0x06, S.READY_TO_SWITCH_ON),  # 8
        (0x0F, S.OPERATION_ENABLED),
        (0x00, S.SWITCH_ON_DISABLED),  # 9
        (0x06, S.READY_TO_SWITCH_ON),
        (0x07, S.SWITCHED_ON),
        (0x02, S.SWITCH_ON_DISABLED),  # 10 (quick stop from switched on)
    ]
    for cw, state in steps:
        assert _cw(node, bench, cw) is state, hex(cw)


def test_quick_stop_options_and_fault_reset(rig) -> None:  # type: ignore[no-untyped-def]
    bench, node, frames = rig
    node.nmt.state = "OPERATIONAL"
    node.sdo[0x6060].raw = 9  # CSV
    for cw in (0x06, 0x0F):
        _cw(node, bench, cw)
    node.sdo[0x60FF].raw = 4096 * 5  # 5 rev/s
    for _ in range(200):
        bench.sync()
    assert _drive(bench).axis.velocity == pytest.approx(2 * math.pi * 5, rel=0.02)
    node.sdo[0x605A].raw = 6  # quick stop ramp, stay in QUICK STOP ACTIVE
    assert _cw(node, bench, 0x0B) is S.QUICK_STOP_ACTIVE  # 11
    for _ in range(400):
        bench.sync()
    assert abs(_drive(bench).axis.velocity) < 0.05
    assert statusword_state(node.sdo[0x6041].raw) is S.QUICK_STOP_ACTIVE
    assert _cw(node, bench, 0x0F) is S.OPERATION_ENABLED  # 16
    node.sdo[0x605A].raw = 2  # quick stop ramp, then SWITCH ON DISABLED (12)
    _cw(node, bench, 0x0B)
    for _ in range(400):
        bench.sync()
    assert statusword_state(node.sdo[0x6041].raw) is S.SWITCH_ON_DISABLED
    # fault (13, 14) by over-speed in voltage mode, then reset (15)
    node.sdo[0x6080].raw = 300  # rpm
    node.sdo[0x6060].raw = -1
    for cw in (0x06, 0x0F):
        _cw(node, bench, cw)
    node.sdo[0x2100].raw = 20000
    for _ in range(400):
        bench.sync()
    assert statusword_state(node.sdo[0x6041].raw) is S.FAULT
    assert node.sdo[0x603F].raw == 0x8400 and node.sdo[0x1001].raw & 0x01
    emcy = [d for cob, d in frames if cob == 0x81]
    assert emcy and struct.unpack_from("<HB", emcy[0]) == (0x8400, node.sdo[0x1001].raw)
    assert _cw(node, bench, 0x00) is S.FAULT
    assert _cw(node, bench, 0x80) is S.SWITCH_ON_DISABLED  # 15, rising edge of bit 7
    assert node.sdo[0x603F].raw == 0


@pytest.mark.parametrize(
    "index,sub,value,code",
    [
        (0x6041, 0, 1, 0x06010002),  # write to read-only
        (0x1008, 0, b"x", 0x06010002),  # write to const
        (0x3000, 0, 1, 0x06020000),  # no such object
        (0x1018, 9, 1, 0x06090011),  # no such sub-index
        (0x6060, 0, 7, 0x06090030),  # mode 7 (IP) not supported
        (0x1A00, 1, 0x60640020, 0x08000022),  # remap while the PDO is valid
    ],
)
def test_sdo_aborts(rig, index: int, sub: int, value: object, code: int) -> None:  # type: ignore[no-untyped-def]
    _, node, _ = rig
    data = value if isinstance(value, bytes) else int(value).to_bytes(4 if index != 0x6060 else 1, "little")  # type: ignore[call-overload]
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo.download(index, sub, data)
    assert exc.value.code == code


def test_pdo_remap_round_trip_takes_effect(rig) -> None:  # type: ignore[no-untyped-def]
    bench, node, frames = rig
    node.tpdo.read()
    tp = node.tpdo[3]
    tp.clear()
    tp.add_variable(0x6078)
    tp.add_variable(0x6064)
    tp.trans_type = 2  # every 2nd SYNC
    tp.enabled = True
    tp.save()
    node.tpdo.read()
    assert [v.index for v in node.tpdo[3].map] == [0x6078, 0x6064]
    with pytest.raises(
        SdoAbortedError
    ) as exc:  # 0x6040 is RPDO-mappable only by data size rules: unknown bits
        node.sdo[0x1A03][0].raw = 0
        node.sdo[0x1A03][1].raw = 0x60400020  # wrong length
    assert exc.value.code in (0x06040041, 0x08000022)
    node.nmt.state = "OPERATIONAL"
    frames.clear()
    for _ in range(4):
        bench.sync()
    tpdo3 = [d for cob, d in frames if cob == 0x381]
    assert len(tpdo3) == 2 and len(tpdo3[0]) == 6


def test_nmt_gating_and_resets(rig) -> None:  # type: ignore[no-untyped-def]
    bench, node, frames = rig
    node.tpdo.read()
    frames.clear()
    bench.sync()
    assert not [c for c, _ in frames if 0x180 <= c < 0x500]  # no PDO in PRE-OPERATIONAL
    node.nmt.state = "OPERATIONAL"
    bench.sync()
    assert [c for c, _ in frames if c == 0x281]  # TPDO2 on SYNC
    node.nmt.state = "STOPPED"
    frames.clear()
    bench.sync()
    assert not [c for c, _ in frames if 0x180 <= c < 0x500]
    with pytest.raises(canopen.SdoCommunicationError):
        node.sdo.RESPONSE_TIMEOUT = 0.01
        node.sdo.MAX_RETRIES = 1
        node.sdo[0x1000].raw  # noqa: B018
    node.sdo.RESPONSE_TIMEOUT = 0.3
    node.nmt.state = "RESET COMMUNICATION"
    assert frames[-1] == (0x701, b"\x00")  # boot-up
    assert node.sdo[0x1000].raw == 0x00020192  # SDO back in PRE-OPERATIONAL
    node.sdo[0x1800][2].raw = 5
    node.nmt.state = "RESET"
    assert node.sdo[0x1800][2].raw == 255  # reset node restores the power-on value


def test_encoder_position_and_speed(rig) -> None:  # type: ignore[no-untyped-def]
    bench, node, frames = rig
    enc = canopen.RemoteNode(2, CIA406_EDS)
    bench.host.add_node(enc)
    assert enc.sdo[0x1000].raw & 0xFFFF == 406
    enc.nmt.state = "OPERATIONAL"
    node.nmt.state = "OPERATIONAL"
    node.sdo[0x6060].raw = 9
    for cw in (0x06, 0x0F):
        node.sdo[0x6040].raw = cw
    node.sdo[0x60FF].raw = 4096  # 1 rev/s
    for _ in range(500):
        bench.sync()
    tpdo2 = [struct.unpack("<Ih", d) for cob, d in frames if cob == 0x282]
    axis = _drive(bench).axis
    assert tpdo2[-1][0] == math.floor(axis.position / (2 * math.pi) * 4096)
    # Euler-backward speed over 0.4 ms is quantised to 2500 counts/s; its mean is the speed
    speeds = [s for _, s in tpdo2[-200:]]
    assert set(speeds) <= {2500, 5000}
    assert sum(speeds) / len(speeds) == pytest.approx(4096, rel=0.02)
    enc.sdo[0x6200].raw = 10  # cyclic timer 10 ms on TPDO1
    frames.clear()
    for _ in range(100):  # 40 ms
        bench.sync()
    assert 4 <= len([c for c, _ in frames if c == 0x182]) <= 5


def test_lockstep_runs_repeat_exactly() -> None:
    def run() -> list[tuple[int, bytes]]:
        bench = LockstepBench("dc-servo", {"load": "sine:0.05:1"})
        out: list[tuple[int, bytes]] = []
        bench.host.bus.listeners.append(lambda m: out.append((m.arbitration_id, bytes(m.data))))
        node = canopen.RemoteNode(1, CIA402_EDS)
        bench.host.add_node(node)
        node.nmt.state = "OPERATIONAL"
        node.sdo[0x6060].raw = -1
        for cw in (0x06, 0x0F):
            node.sdo[0x6040].raw = cw
        node.sdo[0x2100].raw = 3000
        for _ in range(300):
            bench.sync()
        bench.close()
        return out

    assert run() == run()


def test_committed_eds_files_are_what_the_generator_writes() -> None:
    from drivers.maps import build_eds

    for name in build_eds.FILES:
        assert (build_eds.HERE / f"{name}.eds").read_text() == build_eds.eds_of(name), name
        od = canopen.import_od(str(build_eds.HERE / f"{name}.eds"), 5)
        assert od[0x1018][1].default == 0xDB1


def test_im_drive_speed_through_cst_over_the_bus() -> None:
    """im-drive: the host closes a speed loop (Table III PI at 0.5 ms) through CST over the bus."""
    bench = LockstepBench("im-drive", {"load": "step:2:0.6"})
    node = canopen.RemoteNode(1, CIA402_EDS)
    bench.host.add_node(node)
    node.tpdo.read()
    node.rpdo.read()
    node.nmt.state = "OPERATIONAL"
    for cw in (0x06, 0x0F):
        node.sdo[0x6040].raw = cw
    torque = node.rpdo[4]["Target torque"]
    node.rpdo[4]["Controlword"].raw = 0x0F
    node.rpdo[4]["Modes of operation"].raw = 10
    speed = node.tpdo[2]["Velocity actual value"]
    counts_per_rad = 4096 / (2 * math.pi)
    integral, w_ref, k_t, rated = 0.0, 100.0, ImParams().k_t, 5.0
    for k in range(2400):  # 1.2 s: 0.2 s magnetising, then 100 rad/s, load step at 0.6 s
        bench.sync()
        e = (w_ref if k >= 400 else 0.0) - speed.raw / counts_per_rad
        integral += 0.0198 * e
        i_q = 0.4443 * e + integral  # Table III speed PI -> i_q* [A], torque = k_t i_q
        torque.raw = max(-1000, min(1000, round(i_q * k_t / rated * 1000)))  # per mille of 5 N m
        node.rpdo[4].transmit()
    drive = _drive(bench)
    assert drive.axis.velocity == pytest.approx(100.0, abs=1.0)
    assert drive.axis.torque == pytest.approx(2.0 + 0.0022 * 100, abs=0.1)
    bench.close()


def test_emcy_on_following_error_and_over_current() -> None:
    bench = LockstepBench("dc-servo")
    frames: list[tuple[int, bytes]] = []
    bench.host.bus.listeners.append(lambda m: frames.append((m.arbitration_id, bytes(m.data))))
    node = canopen.RemoteNode(1, CIA402_EDS)
    bench.host.add_node(node)
    node.nmt.state = "OPERATIONAL"
    node.sdo[0x6060].raw = 8  # CSP
    node.sdo[0x6065].raw = 100  # following error window [increments]
    for cw in (0x06, 0x0F):
        node.sdo[0x6040].raw = cw
    node.sdo[0x607A].raw = 40960  # 10 rev away at once
    bench.sync()  # taken at this SYNC; the position loop follows it from there
    bench.sync()
    assert node.sdo[0x603F].raw == 0x8611
    assert node.sdo[0x6041].raw & 0x2000  # statusword bit 13
    assert (0x81, struct.pack("<HB5x", 0x8611, node.sdo[0x1001].raw)) in frames
    bench.close()
    # grid converter switched on with no voltage against a 400 V grid: over-current
    grid = LockstepBench("grid-converter")
    node = canopen.RemoteNode(1, CIA402_EDS)
    grid.host.add_node(node)
    node.nmt.state = "OPERATIONAL"
    for cw in (0x06, 0x0F):
        node.sdo[0x6040].raw = cw
    for _ in range(5):
        grid.sync()
    assert node.sdo[0x603F].raw == 0x2310
    assert node.sdo[0x1001].raw & 0x02  # current bit of the error register
    assert statusword_state(node.sdo[0x6041].raw) is S.FAULT
    grid.close()


def test_a_fault_shows_in_the_statusword_at_once(rig) -> None:  # type: ignore[no-untyped-def]
    bench, node, _ = rig
    node.nmt.state = "OPERATIONAL"
    node.sdo[0x6060].raw = -1
    for cw in (0x06, 0x0F):
        node.sdo[0x6040].raw = cw
    bench.sync()
    _drive(bench).raise_fault(0x2310)  # between SYNCs, as fault injection does
    assert statusword_state(node.sdo[0x6041].raw) is S.FAULT_REACTION_ACTIVE
    assert node.sdo[0x603F].raw == 0x2310


def test_device_side_values_follow_sdo_writes_rpdos_and_resets(rig) -> None:  # type: ignore[no-untyped-def]
    """The drive's cached object values: an SDO write, an RPDO and an NMT reset all reach it."""
    bench, node, _ = rig
    drive = _drive(bench)
    assert drive.read(0x6080) == 6000
    node.sdo[0x6080].raw = 300
    assert drive.read(0x6080) == 300  # SDO download
    node.nmt.state = "OPERATIONAL"
    node.rpdo.read()
    node.rpdo[1]["Target voltage mV"].raw = -1234
    node.rpdo[1]["Controlword"].raw = 0x06
    node.rpdo[1].transmit()
    bench.sync()  # a synchronous RPDO is unpacked at the SYNC
    assert drive.read(0x2100) == -1234 and node.sdo[0x2100].raw == -1234
    assert statusword_state(node.sdo[0x6041].raw) is S.READY_TO_SWITCH_ON  # its controlword acted
    drive.write(0x6065, 0, 777)  # device side
    assert node.sdo[0x6065].raw == 777
    node.nmt.state = "RESET"
    assert drive.read(0x6080) == 6000 and drive.read(0x2100) == 0 and drive.read(0x6065) == 4096
    with pytest.raises(ValueError, match="does not fit"):
        drive.write(0x6071, 0, 40000)  # INTEGER16
