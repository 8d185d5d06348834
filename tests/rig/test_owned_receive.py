"""The loop thread reading the bus itself (``rig.host.pacing.OwnedReceive`` on the socketcand
client's ``claim``/``release``), over a real TCP socket from a scripted socketcand server: while
claimed, python-can's notifier thread reads nothing (it parks) and the claiming thread hands every
frame to the network's listeners in order; a burst that came in one segment is handed on whole,
not only up to the frame the cycle waited for; after ``release`` the notifier reads again."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import canopen
import pytest

from drivers.bus import open_bus
from rig.host.pacing import OwnedReceive


def _frame(cob: int, value: int) -> bytes:
    return f"< frame {cob:03X} 1.{value:06d} {value:02X} >".encode()


@pytest.fixture
def link() -> Iterator[tuple[canopen.Network, socket.socket]]:
    """A canopen network on open_bus's socketcand client, and the server's end of its socket."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]
        ends: list[socket.socket] = []

        def serve() -> None:
            end, _ = server.accept()
            end.sendall(b"< hi >")
            for _ in range(2):
                end.recv(256)
                end.sendall(b"< ok >")
            ends.append(end)

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        network = canopen.Network()
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
    reader = OwnedReceive(network)
    reader.claim(others=True)
    try:
        end.sendall(_frame(0x181, 1))
        time.sleep(0.1)  # the notifier had time to read it, were it not parked
        assert seen == []
        assert reader.until(lambda: len(seen) >= 1, 2.0)
    finally:
        reader.release()
    end.sendall(_frame(0x181, 2))
    assert got.wait(2.0)
    deadline = time.monotonic() + 2.0
    while len(seen) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    me = threading.current_thread().name
    assert seen[0] == (me, 1)
    assert seen[1][1] == 2 and seen[1][0] != me  # the notifier's thread again
