"""The link-drop scenario's relay (``rig.faults.wire_probe.LinkRelay``) is as transparent as a
switch: both its sockets have TCP_NODELAY, as the host's client and the emulator's server. With
Nagle's algorithm it held the host's SYNCs and the drive's TPDOs about 40 ms every few dozen
periods (a small write waited for the peer's delayed ACK of the one before), and across
processes every cycle after such a hold was late (CI's '100 late cycles in a row')."""

from __future__ import annotations

import socket

from rig.faults.wire_probe import LinkRelay, wait_for


def test_both_sockets_of_the_relay_send_at_once_and_relay_both_ways() -> None:
    with socket.create_server(("127.0.0.1", 0)) as server:
        relay = LinkRelay(server.getsockname()[1])
        try:
            with socket.create_connection(("127.0.0.1", relay.port), timeout=10.0) as client:
                server.settimeout(10.0)
                upstream, _ = server.accept()
                with upstream:
                    wait_for(lambda: len(relay._sockets) == 2, 10.0, "the relay's two sockets")
                    for s in relay._sockets:
                        assert s.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY), s
                    upstream.settimeout(10.0)
                    client.sendall(b"< send 080 0 >")
                    assert upstream.recv(64) == b"< send 080 0 >"
                    upstream.sendall(b"< frame 181 1.0 00 >")
                    assert client.recv(64) == b"< frame 181 1.0 00 >"
        finally:
            relay.drop()
