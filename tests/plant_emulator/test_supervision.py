"""CiA 301 supervision of the emulated drive: heartbeat consumer 0x1016, RPDO deadline, NMT stop,
and the drive's reaction 0x6007 (CiA 402). The peer is canopen's RemoteNode and raw frames."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import canopen
import pytest
from canopen.sdo import SdoAbortedError

from drivers.maps import CIA402_EDS
from drivers.maps.cia import PowerState as S
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.lockstep import LockstepBench
from tests.plant_emulator.test_canopen_devices import statusword_state
from tests.plant_emulator.test_drive_stops import coasted

PERIOD = 0.4e-3
HOST = 0x7F  #: the host's node id in these tests
V0 = 50.0  #: [rad/s]


class Rig:
    """The dc-servo drive in CSV at V0, a RemoteNode, and the frames the drive sent."""

    def __init__(self) -> None:
        self.bench = LockstepBench("dc-servo")
        self.frames: list[tuple[int, bytes]] = []
        self.bench.host.bus.listeners.append(lambda m: self.frames.append((m.arbitration_id, bytes(m.data))))
        self.node = canopen.RemoteNode(1, CIA402_EDS)
        self.bench.host.add_node(self.node)
        drive = self.bench.devices[0]
        assert isinstance(drive, EmulatedDrive)
        self.drive = drive

    def enable(self) -> None:
        self.node.nmt.state = "OPERATIONAL"
        self.node.sdo[0x6060].raw = 9  # CSV
        for cw in (0x06, 0x0F):
            self.node.sdo[0x6040].raw = cw
        self.node.sdo[0x60FF].raw = round(V0 * 4096 / (2 * math.pi))

    def run(self, seconds: float, *, beat_every: float = 0.0) -> None:
        """SYNCs for ``seconds``; the host's heartbeat every ``beat_every`` s (0: none)."""
        steps = round(seconds / PERIOD)
        every = round(beat_every / PERIOD) if beat_every else 0
        for k in range(steps):
            self.bench.sync()
            if every and k % every == 0:
                self.bench.host.send_message(0x700 + HOST, b"\x05")

    def state(self) -> S:
        return statusword_state(self.node.sdo[0x6041].raw)

    def emcy_codes(self) -> list[int]:
        return [int.from_bytes(d[:2], "little") for cob, d in self.frames if cob == 0x81 and d[:2] != b"\0\0"]


@pytest.fixture
def rig() -> Iterator[Rig]:
    r = Rig()
    yield r
    r.bench.close()


def _consume(rig: Rig, ms: int) -> None:
    rig.node.sdo[0x1016][1].raw = HOST << 16 | ms


@pytest.mark.parametrize(
    ("option", "final", "stopped"),
    [
        (1, S.FAULT, True),  # fault: reaction 0x605E (quick stop ramp), then FAULT
        (2, S.SWITCH_ON_DISABLED, False),  # disable voltage: the motor coasts
        (3, S.SWITCH_ON_DISABLED, True),  # quick stop (0x605A = 2), then SWITCH ON DISABLED
        (0, S.OPERATION_ENABLED, False),  # no action
    ],
)
def test_a_lost_host_heartbeat_triggers_0x6007(rig: Rig, option: int, final: S, stopped: bool) -> None:
    _consume(rig, 50)
    rig.node.sdo[0x6007].raw = option
    rig.enable()
    rig.run(0.3, beat_every=0.02)  # the host beats every 20 ms: all well
    assert rig.state() is S.OPERATION_ENABLED
    assert rig.drive.axis.velocity == pytest.approx(V0, rel=1e-3)
    rig.run(0.3)  # the host is gone
    assert 0x8130 in rig.emcy_codes()
    assert rig.state() is final
    if stopped:
        assert abs(rig.drive.axis.velocity) < 0.05
    elif option == 2:  # coasting on its friction since the loss, 30 ms into these 0.3 s
        assert coasted(rig.drive, V0, 0.3) < rig.drive.axis.velocity < coasted(rig.drive, V0, 0.25)
    else:
        assert rig.drive.axis.velocity == pytest.approx(V0, rel=0.01)
    assert rig.bench.device_network.nodes[1].nmt.state == "PRE-OPERATIONAL"  # 0x1029 sub 1 = 0


def test_the_loss_is_seen_within_the_consumer_time(rig: Rig) -> None:
    _consume(rig, 50)
    rig.enable()
    rig.run(PERIOD, beat_every=PERIOD)  # one beat
    rig.run(0.045)  # 45 ms of silence
    assert 0x8130 not in rig.emcy_codes()
    rig.run(0.01)  # 55 ms
    assert 0x8130 in rig.emcy_codes()


def test_monitoring_starts_with_the_first_heartbeat(rig: Rig) -> None:
    _consume(rig, 50)
    rig.enable()
    rig.run(0.3)  # no heartbeat ever: nothing is missed
    assert rig.state() is S.OPERATION_ENABLED
    assert 0x8130 not in rig.emcy_codes()


def test_two_entries_for_one_node_are_refused(rig: Rig) -> None:
    _consume(rig, 50)
    with pytest.raises(SdoAbortedError) as err:
        rig.node.sdo[0x1016][2].raw = HOST << 16 | 80
    assert err.value.code == 0x06040043
    rig.node.sdo[0x1016][2].raw = (HOST - 1) << 16 | 80  # another node: fine


def test_nmt_stop_while_enabled_stops_the_motor(rig: Rig) -> None:
    """NMT stop of an enabled drive (CiA 402: an abort connection): 0x6007 = 3, quick stop; the
    drive brakes although the node is STOPPED (its control runs on; only the PDOs stop), and a
    later NMT start does not move it."""
    rig.node.sdo[0x6007].raw = 3
    rig.enable()
    rig.run(0.2)
    rig.node.nmt.state = "STOPPED"
    rig.run(0.2)
    assert abs(rig.drive.axis.velocity) < 0.05
    rig.node.nmt.state = "OPERATIONAL"
    rig.run(0.2)
    assert rig.state() is S.SWITCH_ON_DISABLED
    assert abs(rig.drive.axis.velocity) < 0.05


def _rpdo_with_a_deadline(rig: Rig) -> Any:
    """RPDO1 with a deadline of 10 ms (its event timer, sub 5) and the quick stop as 0x6007's
    reaction, sent with the enabled controlword for 100 SYNCs: the drive enabled."""
    rig.node.sdo[0x1400][5].raw = 10  # ms
    rig.node.sdo[0x6007].raw = 3
    rig.enable()
    rig.node.rpdo.read()
    rpdo = rig.node.rpdo[1]
    for _ in range(100):
        rpdo["Controlword"].raw = 0x0F
        rpdo.transmit()
        rig.bench.sync()
    assert rig.state() is S.OPERATION_ENABLED
    return rpdo


def test_an_rpdo_that_stops_coming_times_out(rig: Rig) -> None:
    """RPDO1's event timer (sub 5) as its deadline: EMCY 0x8250 and the 0x6007 reaction."""
    _rpdo_with_a_deadline(rig)
    rig.run(0.02)
    assert 0x8250 in rig.emcy_codes()
    rig.run(0.2)
    assert rig.state() is S.SWITCH_ON_DISABLED


def test_an_rpdo_refused_for_its_length_does_not_feed_the_deadline(rig: Rig) -> None:
    """Frames of 3 bytes on RPDO1's COB-ID (another producer's) are not processed (EMCY 0x8210) and
    do not keep the deadline from expiring: they are not the master's RPDO (they did)."""
    rpdo = _rpdo_with_a_deadline(rig)
    for _ in range(round(0.03 / PERIOD)):
        rig.bench.host.send_message(rpdo.cob_id, b"\x0f\x00\x00")
        rig.bench.sync()
    codes = rig.emcy_codes()
    assert 0x8210 in codes and 0x8250 in codes


def test_a_consumer_entry_written_takes_effect_at_once(rig: Rig) -> None:
    """A write to 0x1016 changes the watch when it is stored, not at the next SYNC: a host that
    clears its entry and leaves (no SYNC after it) is not reported lost later (real time)."""
    rig.enable()
    _consume(rig, 50)
    assert rig.drive.heartbeats.times == {HOST: 0.05}
    rig.run(0.01, beat_every=0.005)
    _consume(rig, 0)
    assert rig.drive.heartbeats.times == {}


@pytest.mark.parametrize("gap", [1.0, 1e-6])
def test_in_lockstep_the_consumer_counts_syncs_not_their_stamps(rig: Rig, gap: float) -> None:
    """``rig emulate --time lockstep`` across processes: a SYNC's stamp is the bus's wall clock
    (slow or fast host alike), the device's time is the SYNC count. A host beating every 20 ms of
    SYNCs is never lost, whatever the stamps; 100 ms of SYNCs without a beat is a loss."""
    rig.drive.lockstep = True
    _consume(rig, 50)
    rig.enable()
    net = rig.bench.device_network
    stamp = 0.0

    def syncs(n: int, *, beat: bool) -> None:
        nonlocal stamp
        for k in range(n):
            stamp += gap
            net.notify(0x80, b"", stamp)
            if beat and k % 50 == 0:
                net.notify(0x700 + HOST, b"\x05", stamp)

    syncs(1000, beat=True)  # 0.4 s of SYNCs, a beat every 20 ms
    assert 0x8130 not in rig.emcy_codes()
    syncs(250, beat=False)  # 100 ms of SYNCs in silence
    assert 0x8130 in rig.emcy_codes()
