"""The loop thread reading the bus itself (``drivers.owned_receive.OwnedReceive`` on the socketcand
client's ``claim``/``release``), over a real TCP socket from a scripted socketcand server: while
claimed, python-can's notifier thread reads nothing (it parks) and the claiming thread hands every
frame to the network's listeners in order; a burst that came in one segment is handed on whole,
not only up to the frame the cycle waited for; after ``release`` the notifier reads again."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Iterator

import canopen
import pytest

from drivers.bus import open_bus
from drivers.owned_receive import OwnedReceive
from tests.drivers.scripted_socketcand import greet


def _frame(cob: int, value: int) -> bytes:
    return f"< frame {cob:03X} 1.{value:06d} {value:02X} >".encode()


def _within(condition: Callable[[], bool], timeout: float = 10.0) -> bool:
    """Whether ``condition()`` comes true within ``timeout`` [s] (a guard against a hang only)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.001)
    return True


def _notifier_reads(network: canopen.Network, me: str) -> list[object]:
    """What each receive of a thread other than ``me`` (python-can's notifier) returned, as it
    returns: a parked one returns None at the end of its cycle."""
    bus, returned = network.bus, []
    recv = bus.recv

    def counted(timeout: float | None = None) -> object:
        msg = recv(timeout)
        if threading.current_thread().name != me:
            returned.append(msg)
        return msg

    bus.recv = counted  # type: ignore[method-assign]  # looked up by the notifier on each call
    return returned


@pytest.fixture
def link() -> Iterator[tuple[canopen.Network, socket.socket]]:
    """A canopen network on open_bus's socketcand client, and the server's end of its socket."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]
        ends: list[socket.socket] = []

        def serve() -> None:
            end, _ = server.accept()
            greet(end)
            ends.append(end)

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        network = canopen.Network()
        network.NOTIFIER_CYCLE = 0.05  # [s] a parked notifier returns after this (canopen: 1 s)
        network.bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)
        network.connect()
        thread.join(5.0)
        try:
            yield network, ends[0]
        finally:
            network.disconnect()
            ends[0].close()


def test_a_burst_in_one_segment_is_handed_on_whole(link: tuple[canopen.Network, socket.socket]) -> None:
    """Five answers of a node that stalled come in one segment; the cycle waits for one, and the
    other four are handed on too (read only up to the awaited one, the rest stayed queued and
    every later cycle acted on a sample that many periods old: a false limit stop)."""
    network, end = link
    seen: list[tuple[str, int]] = []
    network.subscribe(0x181, lambda cob, data, ts: seen.append((threading.current_thread().name, data[0])))
    reader = OwnedReceive(network)
    assert OwnedReceive.possible(network)
    reader.claim(others=True)
    try:
        end.sendall(b"".join(_frame(0x181, v) for v in range(1, 6)))
        assert reader.until(lambda: len(seen) >= 1, 2.0)
    finally:
        reader.release()
    me = threading.current_thread().name
    assert seen == [(me, v) for v in range(1, 6)]


def test_nothing_awaited_comes_within_the_timeout_is_false(
    link: tuple[canopen.Network, socket.socket],
) -> None:
    network, _end = link
    reader = OwnedReceive(network)
    reader.claim(others=True)
    try:
        start = time.monotonic()
        assert not reader.until(lambda: False, 0.05)
        assert time.monotonic() - start >= 0.05
    finally:
        reader.release()


def test_while_claimed_the_notifier_reads_nothing_and_after_release_it_reads_again(
    link: tuple[canopen.Network, socket.socket],
) -> None:
    network, end = link
    seen: list[tuple[str, int]] = []
    got = threading.Event()

    def on_frame(cob: int, data: bytearray, ts: float) -> None:
        seen.append((threading.current_thread().name, data[0]))
        got.set()

    network.subscribe(0x181, on_frame)
    me = threading.current_thread().name
    returned = _notifier_reads(network, me)
    reader = OwnedReceive(network)
    reader.claim(others=True)
    try:
        end.sendall(_frame(0x181, 1))
        # the notifier's receive returned twice since: the second began with the frame there, and
        # read it, were the notifier not parked (a condition; parked, each takes its 50 ms cycle)
        since = len(returned)
        assert _within(lambda: len(returned) >= since + 2), "the notifier's receive never returned"
        assert seen == []
        assert reader.until(lambda: len(seen) >= 1, 2.0)
    finally:
        reader.release()
    end.sendall(_frame(0x181, 2))
    assert got.wait(2.0)
    assert _within(lambda: len(seen) >= 2)
    assert seen[0] == (me, 1)
    assert seen[1][1] == 2 and seen[1][0] != me  # the notifier's thread again


def test_an_answer_that_came_between_two_ticks_is_handed_on_before_the_next_sync(
    link: tuple[canopen.Network, socket.socket],
) -> None:
    """A node stalls over two SYNCs, answers two of the three it owes at the third (that cycle is
    late: it holds a sample two periods old), and the third answer between that tick and the
    next. With the loop reading the bus itself, the next tick hands that answer on before it
    sends its SYNC, as a receive thread would have as it came (a first version left it for the
    next tick's wait, where, while one owed answer at most was carried, it was taken for that
    SYNC's: every later cycle acted on a sample one period old, none counted late); it returns
    with the answer to its own SYNC. (No sleep decides: the order is the node's and the test's;
    a tick's budget is long where an answer is due.)"""
    import select
    import types

    from rig.host.pacing import HostSync

    network, end = link
    third = threading.Event()
    replies = {3: [1, 2], 4: [4]}  # SYNC n -> the values answered on receiving it

    def node() -> None:
        held, count = b"", 0
        while True:
            try:
                chunk = end.recv(4096)
            except OSError:
                return
            if not chunk:
                return
            held += chunk
            while b">" in held:
                line, held = held.split(b">", 1)
                if b"send 080" in line:
                    count += 1
                    if count == 4:
                        third.wait(10.0)
                    end.sendall(b"".join(_frame(0x181, v) for v in replies.get(count, [])))
                    if count == 3:
                        third.wait(10.0)
                        end.sendall(_frame(0x181, 3))

    threading.Thread(target=node, daemon=True).start()
    seen: list[int] = []
    network.subscribe(0x181, lambda cob, data, ts: seen.append(data[0]))
    axis = types.SimpleNamespace(tpdo_cob_ids=lambda: [0x181], tpdos_not_awaited=list)
    pacing = HostSync(network, [axis], 0.05)  # type: ignore[list-item]
    at_sync: list[list[int]] = []  #: what had been handed on when each SYNC went out
    transmit = network.sync.transmit

    def sync() -> None:
        at_sync.append(list(seen))
        transmit()

    network.sync.transmit = sync  # type: ignore[method-assign]
    lates = []
    assert pacing.bus_read_by == "receive thread"
    try:
        with pacing.owning():
            assert pacing.bus_read_by == "loop thread"
            for budget in (0.05, 0.05, 0.05):
                pacing.budget = budget
                pacing.tick()
                lates.append(pacing.late)
            third.set()  # the node sends the third answer now: between the ticks
            assert select.select([network.bus._socket], [], [], 10.0)[0]  # it has come
            pacing.budget = 10.0
            pacing.tick()
            lates.append(pacing.late)
            last = seen[-1]
    finally:
        pacing.close()
    assert lates == [True, True, True, False]
    assert at_sync[3] == [1, 2, 3]  # the third answer handed on before the fourth SYNC
    assert last == 4  # the fourth tick returned with its own SYNC's answer in


def test_a_sender_that_never_pauses_cannot_hold_the_loop(link: tuple[canopen.Network, socket.socket]) -> None:
    """Another client floods the bus (any COB-ID: here one nobody awaits) faster than the loop
    hands frames on: the drain after the wait takes what had come when it began (one read of the
    socket), not every frame that comes while it drains. Taking those too (a first version), the
    tick never returned while the flood went on: no SYNC, no RPDO, until the drive's own deadline
    for its commands ended the run (seen across processes: EMCY 0x8250 within 50 ms of a flood of
    50 000 frames/s on COB-ID 0x123). Each frame handed on here makes the server send the next
    (written before the listener returns), so the supply never ends while the drain reads."""
    import select

    network, end = link
    seen: list[int] = []
    supply = 10_000

    def on_frame(cob: int, data: bytearray, ts: float) -> None:
        seen.append(data[0])
        if len(seen) < supply:
            end.sendall(_frame(0x123, len(seen) % 256))

    network.subscribe(0x123, on_frame)
    reader = OwnedReceive(network)
    reader.claim(others=True)
    try:
        end.sendall(b"".join(_frame(0x123, v) for v in range(1, 4)))
        assert select.select([network.bus._socket], [], [], 10.0)[0]  # they have come
        reader.arrived()
        after_arrived = len(seen)
        assert reader.until(lambda: True, 0.0)
    finally:
        reader.release()
    assert 1 <= after_arrived <= 3, after_arrived  # what one read brings: the three, at most
    assert len(seen) <= 2 * 3, len(seen)  # and the next tick's drain takes what came meanwhile


def test_a_listener_that_raises_stops_the_tick_and_loses_no_frame(
    link: tuple[canopen.Network, socket.socket],
) -> None:
    """A listener raising while the loop thread hands a burst on (canopen's own catches what its
    subscribers raise; a listener of the bus's, as the trace's, does not): the tick raises (the
    loop's safe stop names it), and the frames after the one that raised stay for the receive
    thread, which reads them after ``release`` (the stop's SDO answers come the same way)."""
    import select
    import types

    from rig.host.pacing import HostSync

    network, end = link
    seen: list[tuple[str, int]] = []
    got = threading.Event()

    def tap(msg: object) -> None:
        data = getattr(msg, "data", b"")
        if getattr(msg, "arbitration_id", 0) == 0x181 and data[0] == 2:
            raise RuntimeError("the trace's disk is gone")

    def on_frame(cob: int, data: bytearray, ts: float) -> None:
        seen.append((threading.current_thread().name, data[0]))
        if data[0] == 4:
            got.set()

    assert network.notifier is not None
    network.notifier.listeners = [tap, *network.notifier.listeners]  # as the trace's (rig.host.trace)
    network.subscribe(0x181, on_frame)
    axis = types.SimpleNamespace(tpdo_cob_ids=lambda: [0x181], tpdos_not_awaited=list)
    pacing = HostSync(network, [axis], 10.0)  # type: ignore[list-item]
    try:
        with pytest.raises(RuntimeError, match="disk is gone"), pacing.owning():
            end.sendall(b"".join(_frame(0x181, v) for v in range(1, 5)))
            assert select.select([network.bus._socket], [], [], 10.0)[0]  # type: ignore[union-attr]
            pacing.tick()
        assert got.wait(10.0)  # the receive thread reads again, from where the loop left
    finally:
        pacing.close()
    me = threading.current_thread().name
    assert [v for _, v in seen] == [1, 3, 4]  # 2 went to the listener that raised, and no further
    assert seen[0][0] == me and all(name != me for name, _ in seen[1:])


def test_a_signal_while_claiming_gives_the_reading_back(link: tuple[canopen.Network, socket.socket]) -> None:
    """Ctrl-C or SIGTERM (``rig.host.signals`` raises KeyboardInterrupt in the loop thread) that
    lands while the loop claims the reading (the claim waits, up to 1 s, for the receive thread
    to park): the reading is given back all the same, so the receive thread carries the stop's
    SDO answers. Claimed outside the block that gives it back (a first version), the receive
    thread stayed parked for good and every SDO of the stop went unanswered."""
    import types

    from rig.host.pacing import HostSync

    network, end = link
    bus = network.bus
    got = threading.Event()
    network.subscribe(0x181, lambda cob, data, ts: got.set())
    axis = types.SimpleNamespace(tpdo_cob_ids=lambda: [0x181], tpdos_not_awaited=list)
    pacing = HostSync(network, [axis], 0.05)  # type: ignore[list-item]

    def interrupted(timeout: float | None = None) -> bool:
        raise KeyboardInterrupt  # the signal's handler, while the claim waits

    bus._parked.wait = interrupted  # type: ignore[union-attr]
    try:
        with pytest.raises(KeyboardInterrupt), pacing.owning():
            pass
    finally:
        pacing.close()
    assert bus._owner is None  # type: ignore[union-attr]
    end.sendall(_frame(0x181, 1))
    assert got.wait(10.0)  # the receive thread reads again


def test_a_signal_between_a_read_and_its_parse_splices_no_two_frames(
    link: tuple[canopen.Network, socket.socket], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The loop thread reads the socket itself, and a stop signal (KeyboardInterrupt, raised
    where the main thread is) may land between a read and its parse: that read is lost. The line
    it finished must not be finished by the next read's tail instead (the start of one frame and
    the data of another: a TPDO with a position nobody sent); the cut line is dropped."""
    import select

    import drivers.socketcand_client as client

    network, end = link
    bus = network.bus
    assert isinstance(bus, client.SocketcandBus)
    parse = client.parse_frames
    calls = []

    def interrupted(text: str, channel: object, out: object) -> str:
        calls.append(text)
        if len(calls) == 2:
            raise KeyboardInterrupt  # the signal, between the read and its parse
        return parse(text, channel, out)  # type: ignore[arg-type]

    monkeypatch.setattr(client, "parse_frames", interrupted)
    bus.claim(others=True)
    try:
        for chunk in (b"< frame 181 1.000001 0102", b"0304 >< frame 181 1.000002 AABB", b"CCDD >"):
            end.sendall(chunk)
            assert select.select([bus._socket], [], [], 10.0)[0]
            if len(calls) == 1:
                with pytest.raises(KeyboardInterrupt):
                    bus.fill()
            else:
                bus.fill()
        frames = [bus.recv(0.0) for _ in range(bus.fill())]
    finally:
        bus.release()
    assert [bytes(m.data).hex() for m in frames if m is not None] == []
