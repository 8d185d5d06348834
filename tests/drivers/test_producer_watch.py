"""``ProducerWatch``: frames on a TPDO's COB-ID counted against the SYNCs on the bus, and the travel
a drive's own speed allows between two samples. In this process, frames handed to the network as
its receive thread would (``Network.notify``): deterministic."""

from __future__ import annotations

import math
import struct
import uuid
from collections.abc import Iterator

import can
import canopen
import pytest

from drivers.canopen_axis import TpdoSlot
from drivers.producer_watch import ProducerWatch, travel_band

COB = 0x181
CODEC = struct.Struct("<Hi")  #: statusword, position


@pytest.fixture
def network() -> Iterator[canopen.Network]:
    net = canopen.Network()
    net.bus = can.Bus(interface="virtual", channel=f"producers-{uuid.uuid4().hex}")
    yield net
    net.bus.shutdown()


def _slot(network: canopen.Network, watch: ProducerWatch, ttype: int = 1) -> TpdoSlot:
    slot = TpdoSlot(1, COB, CODEC)
    slot.ttype = ttype
    watch.watch(slot)
    network.subscribe(COB, slot.on_frame)
    return slot


def _sync(network: canopen.Network) -> None:
    network.send_message(0x080, b"")


def _answer(network: canopen.Network, position: int, at: float) -> None:
    network.notify(COB, CODEC.pack(0x0237, position), at)


def test_one_answer_a_sync_then_a_second_frame_is_another_producer(network: canopen.Network) -> None:
    watch = ProducerWatch(network)
    slot = _slot(network, watch)
    for k in range(1, 4):
        _sync(network)
        _answer(network, 100 * k, k * 0.001)
    assert not watch.alarm and slot.data == CODEC.pack(0x0237, 300)
    network.notify(COB, CODEC.pack(0x0237, 999), 0.0035)  # a replay between two SYNCs
    assert watch.alarm
    assert watch.intruder(1) == (
        "node 1: another producer on COB-ID 0x181 (a TPDO of node 1): 4 frames for 3 SYNCs, where type 1 "
        "answers once a SYNC, which node 1 did not send"
    )
    assert watch.intruder(2) is None
    assert slot.data == CODEC.pack(0x0237, 300)  # not taken, nor anything after it on that COB-ID
    _sync(network)
    _answer(network, 400, 0.004)
    assert slot.data == CODEC.pack(0x0237, 300) and watch.found[COB].syncs == 3


def test_a_burst_of_owed_answers_after_a_stall_is_no_surplus(network: canopen.Network) -> None:
    """A drive that stalled answers the SYNCs it missed in a burst: as many frames as SYNCs."""
    watch = ProducerWatch(network)
    slot = _slot(network, watch)
    for _ in range(5):
        _sync(network)
    for k in range(5):
        _answer(network, k, 0.01)
    assert not watch.alarm and slot.frames == 5
    _answer(network, 5, 0.01)
    assert watch.alarm


def test_a_frame_of_another_length_is_not_its_node_s(network: canopen.Network) -> None:
    watch = ProducerWatch(network)
    slot = _slot(network, watch)
    _sync(network)
    network.notify(COB, b"\x01\x02\x03", 0.001)
    assert slot.timestamp is None
    assert "a frame of 3 bytes where its mapping has 6, which node 1 did not send" in str(watch.intruder(1))


@pytest.mark.parametrize(("ttype", "syncs", "allowed"), [(2, 5, 3), (10, 9, 1), (10, 10, 2), (0, 4, 4)])
def test_every_nth_sync_allows_syncs_over_n_and_one(
    network: canopen.Network, ttype: int, syncs: int, allowed: int
) -> None:
    """Type n answers every n-th SYNC from a start the host does not know; type 0 (acyclic
    synchronous) at most once a SYNC; event-driven types have no bound."""
    watch = ProducerWatch(network)
    _slot(network, watch, ttype)
    for _ in range(syncs):
        _sync(network)
    for k in range(allowed):
        _answer(network, k, 0.0)
    assert not watch.alarm
    _answer(network, allowed, 0.0)
    assert watch.alarm and f"where type {ttype} answers" in str(watch.intruder(1))


def test_event_driven_tpdos_are_not_counted(network: canopen.Network) -> None:
    watch = ProducerWatch(network)
    _slot(network, watch, 255)
    for k in range(10):
        _answer(network, k, 0.0)
    assert not watch.alarm


def test_syncs_heard_count_and_an_echo_of_the_host_s_own_does_not(network: canopen.Network) -> None:
    """A SYNC heard (the kernel's broadcast manager, another device) is one the nodes answer; on
    a bus that gives the host its own frames back, a SYNC heard while its own is due back is it."""
    echoes = False
    watch = ProducerWatch(network, echoes=lambda: echoes)
    network.notify(0x080, b"", 0.0)
    assert watch.syncs == 1
    echoes = True
    _sync(network)
    network.notify(0x080, b"", 0.0)  # its echo
    assert watch.syncs == 2
    network.notify(0x080, b"", 0.0)  # another one's
    assert watch.syncs == 3


def test_close_gives_the_network_its_own_send_back(network: canopen.Network) -> None:
    watch = ProducerWatch(network)
    assert "send_message" in vars(network)
    watch.close()
    assert "send_message" not in vars(network) and not network.subscribers.get(0x080)


def test_a_stop_on_a_sample_is_named_for_a_producer_found_by_the_next_answers(
    network: canopen.Network,
) -> None:
    watch = ProducerWatch(network)
    _slot(network, watch)
    _sync(network)
    network.notify(COB, CODEC.pack(0x0000, 7), 0.0)  # taken for the answer: its statusword stops the run
    mark = watch.syncs
    _sync(network)  # the stop's first SYNC
    _answer(network, 1, 0.0)  # the node's own answer to the SYNC before, late: 2 frames, 2 SYNCs
    assert watch.cause("y", mark) == "y"
    _answer(network, 2, 0.0)  # and to the stop's SYNC: one frame more than SYNCs
    said = watch.cause("node 1: the drive left OPERATION ENABLED", mark)
    assert said.startswith("node 1: another producer on COB-ID 0x181")
    assert said.endswith(
        "; the run had stopped on a sample it may have sent: node 1: the drive left OPERATION ENABLED"
    )
    assert watch.cause("x", mark - 1) == "x"  # found after that stop's next SYNC: not its cause


def test_travel_band() -> None:
    q, a = (0.001, 0.01), 1.0e4  # a count, a speed unit; at most 10^4 rad/s^2
    # at a steady 10 rad/s over 1 ms: 10 mrad, give or take what a dt^2/4 (speeding up and back)
    # adds, a speed unit's travel and two counts
    steady = travel_band(10.0, 10.0, 1e-3, 1e-3, resolution=q, accel=a)
    assert steady == pytest.approx((0.01 - 0.0025 - 1e-5 - 0.002, 0.01 + 0.0025 + 1e-5 + 0.002))
    # from 10 to 20 rad/s in 1 ms takes all of 10^4 rad/s^2: the ramp's 15 mrad only
    lo, hi = travel_band(10.0, 20.0, 1e-3, 1e-3, resolution=q, accel=a)
    assert lo == pytest.approx(0.015 - 1e-5 - 0.002) and hi == pytest.approx(0.015 + 1e-5 + 0.002)
    # at rest at both: up and back within the period, either way
    rest = travel_band(0.0, 0.0, 1e-3, 1e-3, resolution=(0.0, 0.0), accel=a)
    assert rest == pytest.approx((-0.0025, 0.0025))
    # an elapsed time from 0 to 3 ms (real time): from braking to rest at once to speeding up all along
    lo, hi = travel_band(10.0, 10.0, 0.0, 3e-3, resolution=q, accel=a)
    assert hi == pytest.approx(10.01 * 3e-3 + 0.5 * a * 9e-6 + 0.002)
    assert lo == pytest.approx(-0.5 * a * (3e-3 - 9.99 / a) ** 2 - 0.002)
    lo, hi = travel_band(-10.0, 5.0, 0.0, 3e-3, resolution=q, accel=a)  # through zero
    assert lo < -0.03 and hi > 0.015
    # no acceleration said: no band (only the speed limit bounds the travel)
    assert travel_band(10.0, 10.0, 1e-3, 1e-3, resolution=q, accel=math.inf) is None
