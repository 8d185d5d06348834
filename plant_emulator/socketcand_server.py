"""A socketcand-compatible server (rawmode) in front of an in-process ``SyncHub``.

For machines without kernel CAN (this one, macOS, Windows): python-can's
``socketcand`` interface is the client, so a host process opens
``can.Bus(interface="socketcand", host="127.0.0.1", port=P, channel="can0")``
and sees the emulated devices as on a real bus. Protocol (socketcand's
rawmode): the server greets ``< hi >``; the client sends ``< open CH >`` and
``< rawmode >``, each answered ``< ok >``; then the client sends
``< send ID DLC B0 B1 ... >`` and receives ``< frame ID SEC.USEC HEXDATA >``.

Every frame a client sends goes to the hub (the devices answer at once, under
one lock) and to the other clients; every frame the devices send goes to all
clients. Timestamps are wall-clock seconds.
"""

from __future__ import annotations

import logging
import socket
import socketserver
import threading
import time

import can

from plant_emulator.lockstep import SyncHub

__all__ = ["SocketcandServer", "format_frame", "parse_send"]

log = logging.getLogger(__name__)


def parse_send(text: str) -> can.Message:
    """``< send ID DLC B0 ... >`` -> Message; ValueError naming the text when malformed."""
    parts = text.strip("<> \r\n").split()
    if len(parts) < 3 or parts[0] != "send":
        raise ValueError(f"socketcand: not a send command: {text!r}")
    can_id, dlc = int(parts[1], 16), int(parts[2], 16)
    data = bytes(int(b, 16) for b in parts[3 : 3 + dlc])
    if len(data) != dlc or dlc > 8:
        raise ValueError(f"socketcand: DLC {dlc} does not match the data in {text!r}")
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=len(parts[1]) > 3)


def format_frame(msg: can.Message) -> str:
    """Message -> ``< frame ID SEC.USEC HEXDATA >`` (python-can's socketcand parser)."""
    can_id = f"{msg.arbitration_id:08X}" if msg.is_extended_id else f"{msg.arbitration_id:03X}"
    return f"< frame {can_id} {msg.timestamp:.6f} {bytes(msg.data).hex().upper()} >"


class SocketcandServer:
    """Serve ``hub`` on TCP ``host``:``port`` (0: any free port; see ``port`` after start)."""

    def __init__(self, hub: SyncHub, lock: threading.RLock, *, host: str = "127.0.0.1", port: int = 29536):
        self.hub = hub
        self.lock = lock
        self.clients: list[socket.socket] = []
        self.bus = hub.bus(queue=False, channel="socketcand")
        self.bus.listeners.append(self._to_clients)
        outer = self

        class Handler(socketserver.BaseRequestHandler):
            def handle(self) -> None:
                outer._serve(self.request)

        class Server(socketserver.ThreadingTCPServer):
            allow_reuse_address = True
            daemon_threads = True

        self.server = Server((host, port), Handler)
        self.port = int(self.server.server_address[1])
        self._thread = threading.Thread(target=self.server.serve_forever, name="socketcand", daemon=True)

    def start(self) -> None:
        self._thread.start()
        log.info("socketcand rawmode server on %s:%d", *self.server.server_address[:2])

    def stop(self) -> None:
        if self._thread.is_alive():  # socketserver's shutdown() waits forever for a loop never started
            self.server.shutdown()
        self.server.server_close()
        for c in list(self.clients):
            c.close()
        self.bus.shutdown()

    def _send(self, sock: socket.socket, text: str) -> None:
        try:
            sock.sendall(text.encode("ascii"))
        except OSError:
            if sock in self.clients:
                self.clients.remove(sock)

    def _to_clients(self, msg: can.Message) -> None:
        text = format_frame(msg)
        for c in list(self.clients):
            self._send(c, text)

    def _serve(self, sock: socket.socket) -> None:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._send(sock, "< hi >")
        buffer = ""
        rawmode = False
        while True:
            try:
                chunk = sock.recv(4096)
            except OSError:
                break
            if not chunk:
                break
            buffer += chunk.decode("ascii", errors="replace")
            while ">" in buffer:
                command, _, buffer = buffer.partition(">")
                command = command.strip() + " >"
                if command.startswith("< open"):
                    self._send(sock, "< ok >")
                elif command.startswith("< rawmode"):
                    self._send(sock, "< ok >")
                    rawmode = True
                    with self.lock:
                        self.clients.append(sock)
                elif command.startswith("< send") and rawmode:
                    try:
                        msg = parse_send(command)
                    except ValueError as exc:
                        log.warning("%s", exc)
                        self._send(sock, "< error bad send >")
                        continue
                    with self.lock:
                        self.hub.clock = time.time()
                        for other in self.clients:
                            if other is not sock:
                                self._send(other, format_frame(self._stamped(msg)))
                        self.bus.send(msg)
                elif command.strip("<> "):
                    log.warning("socketcand: unsupported command %r", command)
        with self.lock:
            if sock in self.clients:
                self.clients.remove(sock)

    def _stamped(self, msg: can.Message) -> can.Message:
        msg.timestamp = self.hub.clock
        return msg
