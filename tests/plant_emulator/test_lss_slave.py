"""The emulated nodes answer LSS as a CiA 305 slave does (``plant_emulator.lss_slave``), seen from
canopen's LSS master (``network.lss``) and from raw frames, in lock-step: a drive fresh from the box
(node-ID 255) is silent but for LSS until it is given a node-ID, then boots with it; a configured
drive takes a new node-ID at its next NMT reset communication and keeps it over a reset node only
if it was stored; each service answers as the standard says, errors included."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import canopen
import pytest
from canopen.lss import LssError

from drivers.maps.lss import COB_MASTER, COB_SLAVE, Cs
from plant_emulator.device_profile import device_profile
from plant_emulator.lockstep import LockstepBench

TOOLKIT = (0xDB1, 0x402, 0x00010000, 0x00000001)  #: the toolkit's drive's 0x1018 sub 1-4


class Bench:
    """A twin on a lock-step hub, with every frame on the wire kept."""

    def __init__(self, device: str, node_id: int) -> None:
        profile = dataclasses.replace(device_profile(device), node_id=node_id)
        self.frames: list[tuple[int, bytes]] = []
        self.bench = LockstepBench(profile.physics, device=profile)
        self.bench.hub.taps.append(lambda m: self.frames.append((m.arbitration_id, bytes(m.data))))
        self.drive: Any = self.bench.devices[0]
        self.host: Any = self.bench.host
        self.lss: Any = self.host.lss
        self.lss.RESPONSE_TIMEOUT = 0.01  # lock-step: an answer comes within the request's send
        self.eds = str(profile.eds)

    def sent(self, cob_id: int) -> list[bytes]:
        return [data for cob, data in self.frames if cob == cob_id]

    def raw(self, *frame: int) -> list[bytes]:
        """The slave's answers to one LSS frame (8 bytes, zeros after ``frame``)."""
        self.frames.clear()
        self.host.send_message(COB_MASTER, bytes(frame).ljust(8, b"\0"))
        return self.sent(COB_SLAVE)

    def node(self, node_id: int) -> Any:
        node = canopen.RemoteNode(node_id, self.eds)
        node.sdo.RESPONSE_TIMEOUT = 0.01
        self.host.add_node(node)
        return node


@pytest.fixture
def fresh() -> Iterator[Bench]:
    bench = Bench("drive-rig", 255)  # its heartbeat, once it has a node-ID: 100 ms
    yield bench
    bench.bench.close()


@pytest.fixture
def configured() -> Iterator[Bench]:
    bench = Bench("drive-rig", 1)  # the toolkit's drive: LSS, heartbeat 100 ms, 250/500/1000 kbit/s
    yield bench
    bench.bench.close()


def _u32(value: int) -> list[int]:
    return list(value.to_bytes(4, "little"))


def test_a_drive_without_a_node_id_is_silent_but_for_lss_until_it_has_one(fresh: Bench) -> None:
    assert fresh.frames == [] and fresh.drive.node_id == 255  # no boot-up at power-on
    fresh.host.send_message(0, bytes([0x01, 0]))  # NMT start all: not for a node without a node-ID
    syncs = round(0.25 / fresh.bench.period)  # 250 ms: its heartbeat would have come twice
    for _ in range(syncs):
        fresh.bench.sync()
    assert [cob for cob, _ in fresh.frames] == [0, *[0x080] * syncs]  # the host's own frames only
    found, address = fresh.lss.fast_scan()
    assert found and tuple(address) == TOOLKIT
    assert fresh.lss.inquire_node_id() == 255
    fresh.lss.configure_node_id(5)
    fresh.frames.clear()
    fresh.lss.send_switch_state_global(fresh.lss.WAITING_STATE)
    assert fresh.sent(0x705) == [b"\x00"] and fresh.drive.node_id == 5  # it boots as node 5
    node = fresh.node(5)
    assert node.sdo[0x1018][4].raw == 1
    assert node.sdo[0x1800][1].raw == 0x185 and node.sdo[0x1014].raw == 0x85  # $NODEID+0x180, +0x80
    assert fresh.raw(Cs.IDENTIFY_NON_CONFIGURED) == []  # configured now


def test_a_configured_drive_takes_a_new_node_id_at_reset_communication_and_keeps_it_if_stored(
    configured: Bench,
) -> None:
    lss = configured.lss
    assert lss.send_switch_state_selective(*TOOLKIT)
    inquired = [lss.inquire_lss_address(cs) for cs in range(Cs.INQUIRE_VENDOR, Cs.INQUIRE_SERIAL + 1)]
    assert inquired == list(TOOLKIT)
    assert lss.inquire_node_id() == 1
    lss.configure_node_id(9)
    lss.send_switch_state_global(lss.WAITING_STATE)
    assert configured.drive.node_id == 1  # pending
    configured.frames.clear()
    configured.host.send_message(0, bytes([0x82, 1]))  # NMT reset communication of node 1
    assert configured.sent(0x709) == [b"\x00"] and configured.drive.node_id == 9
    configured.host.send_message(0, bytes([0x81, 9]))  # reset node: the stored node-ID, 1
    assert configured.drive.node_id == 1
    lss.send_switch_state_global(lss.CONFIGURATION_STATE)
    lss.configure_node_id(9)
    lss.store_configuration()
    lss.send_switch_state_global(lss.WAITING_STATE)
    configured.host.send_message(0, bytes([0x81, 1]))  # reset node: node 9 now, stored
    assert configured.drive.node_id == 9
    configured.host.send_message(0, bytes([0x81, 9]))
    assert configured.drive.node_id == 9
    for _ in range(round(0.12 / configured.bench.period)):  # its heartbeat (100 ms), as node 9
        configured.bench.sync()
    assert configured.sent(0x709)[-1] == b"\x7f" and configured.sent(0x701) == [b"\x00"]


def test_each_service_answers_as_cia_305_says(configured: Bench) -> None:
    raw, lss = configured.raw, configured.lss
    assert raw(Cs.INQUIRE_NODE_ID) == []  # waiting: no inquiry answered
    assert raw(Cs.IDENTIFY_NON_CONFIGURED) == []  # it has a node-ID
    lo_hi = [*_u32(0), *_u32(0xFFFFFFFF)]
    identify = [(Cs.IDENTIFY_VENDOR, 0xDB1), (Cs.IDENTIFY_VENDOR + 1, 0x402)]
    for cs, value in identify:
        assert raw(cs, *_u32(value)) == []
    assert raw(Cs.IDENTIFY_VENDOR + 2, *lo_hi[:4]) == [] and raw(Cs.IDENTIFY_VENDOR + 3, *lo_hi[4:]) == []
    assert raw(Cs.IDENTIFY_VENDOR + 4, *_u32(2)) == []
    assert raw(Cs.IDENTIFY_SERIAL_HIGH, *_u32(5)) == []  # serial 1 is below 2..5
    for cs, value in (*identify, (0x48, 0), (0x49, 0xFFFFFFFF), (0x4A, 0)):
        raw(cs, *_u32(value))
    assert raw(Cs.IDENTIFY_SERIAL_HIGH, *_u32(1)) == [bytes([Cs.IDENTIFY_SLAVE]).ljust(8, b"\0")]
    assert raw(Cs.SWITCH_GLOBAL, 1) == []
    assert raw(Cs.INQUIRE_NODE_ID) == [bytes([Cs.INQUIRE_NODE_ID, 1]).ljust(8, b"\0")]
    assert raw(Cs.INQUIRE_NODE_ID, 0, 0) == raw(Cs.INQUIRE_NODE_ID)
    configured.host.send_message(COB_MASTER, bytes([Cs.INQUIRE_NODE_ID]))  # not 8 bytes: ignored
    assert configured.sent(COB_SLAVE) == [bytes([Cs.INQUIRE_NODE_ID, 1]).ljust(8, b"\0")]
    for node in (0, 128, 200):
        assert raw(Cs.CONFIGURE_NODE_ID, node) == [bytes([Cs.CONFIGURE_NODE_ID, 1]).ljust(8, b"\0")]
    with pytest.raises(LssError, match="LSS Error: 1"):
        lss.configure_bit_timing(1)  # 800 kbit/s: not in its EDS's BaudRate_ list
    assert raw(Cs.CONFIGURE_BIT_TIMING, 0, 5) == [bytes([Cs.CONFIGURE_BIT_TIMING, 1]).ljust(8, b"\0")]
    assert raw(Cs.CONFIGURE_BIT_TIMING, 1, 2) == [bytes([Cs.CONFIGURE_BIT_TIMING, 1]).ljust(8, b"\0")]
    lss.configure_bit_timing(2)  # 500 kbit/s
    lss.activate_bit_timing(10)
    assert configured.drive.lss.bitrate == 500_000
    lss.store_configuration()
    assert configured.drive.lss.stored_bitrate == 500_000


def test_fastscan_is_for_drives_without_a_node_id_only(configured: Bench) -> None:
    found, address = configured.lss.fast_scan()
    assert not found and address is None
