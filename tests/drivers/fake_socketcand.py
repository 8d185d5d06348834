"""The independent fake device in a process of its own, behind a socketcand rawmode server.

Written without drive-rig's code, like ``fake_device.py``: ``python -m tests.drivers.fake_socketcand
NAME [NAME@NODE ...] --port P --log FILE`` serves each dictionary of ``dictionaries/`` (node 1, or
the node given) on a python-can virtual channel, and a TCP server on 127.0.0.1:P speaks
socketcand's rawmode to any number of clients (python-can's ``socketcand`` interface): each
client is a bus of its own on that channel, so it gets every frame but its own, as on SocketCAN.
The port it took is printed (``port N``) once it listens; SIGTERM or SIGINT writes the devices'
logs to FILE (JSON: per node, every SDO download and upload, RPDO and NMT frame) and ends it.

Protocol (socketcand's README, rawmode): the server greets ``< hi >``; ``< open CH >`` and
``< rawmode >`` are each answered ``< ok >``; then ``< send ID DLC B0 B1 ... >`` from a client
puts a frame on the bus, and every other frame goes to it as ``< frame ID SEC.USEC HEX >``.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import signal
import socket
import socketserver
import sys
import threading
import time
import uuid
from typing import Any

import can

from tests.drivers.fake_device import Dictionary, FakeDrive


class _Client(socketserver.BaseRequestHandler):
    channel = ""

    def handle(self) -> None:
        sock: socket.socket = self.request
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.sendall(b"< hi >")
        buf = b""
        bus: can.BusABC | None = None
        try:
            while True:
                chunk = sock.recv(4096)
                if not chunk:
                    return
                buf += chunk
                while b">" in buf:
                    line, _, buf = buf.partition(b">")
                    words = line.decode("ascii", "replace").strip().lstrip("<").split()
                    if not words:
                        continue
                    if words[0] == "open":
                        sock.sendall(b"< ok >")
                    elif words[0] == "rawmode" and bus is None:
                        sock.sendall(b"< ok >")
                        bus = can.Bus(interface="virtual", channel=self.channel)
                        threading.Thread(target=_to_client, args=(bus, sock), daemon=True).start()
                    elif words[0] == "send" and bus is not None:
                        data = bytes(int(b, 16) for b in words[3:])
                        bus.send(
                            can.Message(arbitration_id=int(words[1], 16), data=data, is_extended_id=False)
                        )
        except OSError:
            return
        finally:
            if bus is not None:
                bus.shutdown()


def _to_client(bus: can.BusABC, sock: socket.socket) -> None:
    """Every frame of the channel but the client's own, from its rawmode ``< ok >`` on, with no
    pause: frames may come in the segment of the ``< ok >``, as from socketcand on a busy bus
    (drive-rig's client keeps them; python-can's own refuses that ``< ok >``)."""
    while True:
        try:
            msg = bus.recv(0.05)
        except Exception:
            return
        if msg is None:
            continue
        stamp = time.time()
        try:
            sock.sendall(
                f"< frame {msg.arbitration_id:03X} {stamp:.6f} {bytes(msg.data).hex().upper()} >".encode()
            )
        except OSError:
            return


class _Server(socketserver.ThreadingTCPServer):
    daemon_threads = True
    allow_reuse_address = True


def log_of(fake: FakeDrive) -> dict[str, Any]:
    with fake._lock:
        return {
            "downloads": [
                [i, s, v if not isinstance(v, bytes) else v.hex(), a] for i, s, v, a in fake.downloads
            ],
            "uploads": [list(u) for u in fake.uploads],
            "rpdos": [[c, d.hex()] for c, d in fake.rpdos],
            "rpdo_writes": [list(w) for w in fake.rpdo_writes],
            "nmt": [list(n) for n in fake.nmt_log],
            "state": fake.state,
            "nmt_state": fake.nmt,
        }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("drives", nargs="+", help="NAME or NAME@NODE of dictionaries/")
    p.add_argument("--port", type=int, default=0)
    p.add_argument("--log", required=True)
    args = p.parse_args(argv)
    channel = f"fake-{uuid.uuid4().hex}"
    fakes = []
    for spec in args.drives:
        name, _, node = spec.partition("@")
        fakes.append(FakeDrive(Dictionary.load(name), channel, int(node or 1)))
    handler = type("Client", (_Client,), {"channel": channel})
    server = _Server(("127.0.0.1", args.port), handler)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    signal.signal(signal.SIGINT, lambda *_: done.set())
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
    print(f"port {server.server_address[1]}", flush=True)
    done.wait()
    server.shutdown()
    logs = {str(f.node): log_of(f) for f in fakes}
    pathlib.Path(args.log).write_text(json.dumps(logs))
    for f in fakes:
        f.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
