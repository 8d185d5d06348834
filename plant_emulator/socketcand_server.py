"""A socketcand-compatible server (rawmode) in front of an in-process ``SyncHub``.

For machines without kernel CAN (this one, macOS, Windows): python-can's
``socketcand`` interface is the client, so a host process opens
``can.Bus(interface="socketcand", host="127.0.0.1", port=P, channel="can0")``
and sees the emulated devices as on a real bus. Protocol (socketcand's
rawmode, ``socketcand_protocol``): the server greets ``< hi >``; the client sends
``< open CH >`` and ``< rawmode >``, each answered ``< ok >``; then the client sends
``< send ID DLC B0 B1 ... >`` and receives ``< frame ID SEC.USEC HEXDATA >``. A command
refused (a bad id, DLC or byte, a second ``< rawmode >``, an unknown verb) is answered
``< error WHAT >`` and reaches nobody; one of more than ``MAX_COMMAND`` bytes drops the client.

Every frame a client sends goes to the hub (the devices answer at once, under
one lock) and to the other clients; every frame the devices send goes to all
clients. Each client has its own bounded queue and writer thread
(``socketcand_link``): a client that does not read is dropped, and no socket is
written with the devices' lock held. Timestamps are wall-clock seconds (time.time(), as
socketcand stamps frames): a device frame carries the moment it was sent, a client's
frame the moment the server took it, which is also the ``hub.clock`` the devices see
it at.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import socketserver
import threading
import time

import can

from plant_emulator.lockstep import SyncHub
from plant_emulator.socketcand_link import ClientLink, check_limits
from plant_emulator.socketcand_protocol import (
    MAX_COMMAND,
    CommandSplitter,
    CommandTooLong,
    ProtocolError,
    command_words,
    format_frame,
    parse_send,
    shown,
)

__all__ = ["MAX_COMMAND", "SocketcandServer", "format_frame", "parse_send"]

log = logging.getLogger(__name__)

_CHUNK = 65536  #: [bytes] read at a time
_BUS_NAME = 16  #: the longest bus name socketcand takes


class SocketcandServer:
    """Serve ``hub`` on TCP ``host``:``port`` (0: any free port; see ``port`` after start).

    ``lock`` is the devices' lock. Each client may have ``queue_depth`` lines waiting and
    ``send_timeout`` [s] to take one; ``send_buffer`` [bytes] sets the kernel's send buffer
    of each client socket (None: the system's).
    """

    def __init__(
        self,
        hub: SyncHub,
        lock: threading.RLock,
        *,
        host: str = "127.0.0.1",
        port: int = 29536,
        queue_depth: int = 4096,
        send_timeout: float = 2.0,
        send_buffer: int | None = None,
    ):
        check_limits(queue_depth, send_timeout)
        self.hub = hub
        self.lock = lock
        self.queue_depth, self.send_timeout, self.send_buffer = queue_depth, send_timeout, send_buffer
        self._registry = threading.Lock()
        self._clients: tuple[ClientLink, ...] = ()  #: in rawmode: they get every frame
        self._connected: set[ClientLink] = set()
        self.bus = hub.bus(queue=False, channel="socketcand")
        self.bus.listeners.append(self._to_clients)
        outer = self

        class Handler(socketserver.BaseRequestHandler):
            def handle(self) -> None:
                outer._serve(self.request)

        class Server(socketserver.ThreadingTCPServer):
            allow_reuse_address = True
            daemon_threads = True

        try:
            self.server = Server((host, port), Handler)
        except OSError:
            self.bus.shutdown()  # nothing is served: the hub's bus goes too, not left to the collector
            raise
        self.port = int(self.server.server_address[1])
        self._thread = threading.Thread(
            target=self.server.serve_forever, args=(0.1,), name="socketcand", daemon=True
        )

    @property
    def client_count(self) -> int:
        """Clients in rawmode now."""
        return len(self._clients)

    def start(self) -> None:
        self._thread.start()
        log.info("socketcand rawmode server on %s:%d", *self.server.server_address[:2])

    def stop(self) -> None:
        if self._thread.is_alive():  # socketserver's shutdown() waits forever for a loop never started
            self.server.shutdown()
        self.server.server_close()
        with self._registry:
            connected = list(self._connected)
        for client in connected:
            client.drop("the server stops", logging.INFO)
        self.bus.shutdown()

    def _to_clients(self, msg: can.Message) -> None:
        """A device's frame (called under the devices' lock): queued for every client, stamped now."""
        line = format_frame(msg, time.time())
        for client in self._clients:
            client.put(line)

    def _serve(self, sock: socket.socket) -> None:
        with contextlib.suppress(OSError):  # a client gone already: its first recv says so
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            if self.send_buffer is not None:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.send_buffer)
        client = ClientLink(sock, depth=self.queue_depth, send_timeout=self.send_timeout)
        with self._registry:
            self._connected.add(client)
        reason = None
        try:
            client.reply("< hi >")
            reason = self._read(client)
        finally:
            with self._registry:
                self._clients = tuple(c for c in self._clients if c is not client)
                self._connected.discard(client)
            client.finish(reason)

    def _read(self, client: ClientLink) -> str | None:
        """Serve ``client``'s commands until it leaves (None) or must be dropped (why)."""
        splitter = CommandSplitter(MAX_COMMAND)
        while not client.closed.is_set():
            try:
                chunk = client.sock.recv(_CHUNK)
            except TimeoutError:
                continue  # an idle client: look at ``closed`` again
            except OSError:
                return None
            if not chunk:
                client.eof = True
                return None
            try:
                for text in splitter.feed(chunk):
                    self._command(client, text)
            except CommandTooLong as exc:
                client.reply(f"< error {exc} >")
                return str(exc)
        return None

    def _command(self, client: ClientLink, text: str) -> None:
        """Do one command; a refused one is answered ``< error ... >`` (the first is logged)."""
        try:
            self._dispatch(client, text)
        except ProtocolError as exc:
            client.errors += 1
            level = logging.WARNING if client.errors == 1 else logging.DEBUG
            log.log(level, "socketcand: client %s: %s (%d refused so far)", client.name, exc, client.errors)
            client.reply(f"< error {exc} >")

    def _dispatch(self, client: ClientLink, text: str) -> None:
        words = command_words(text)
        verb = words[0]
        if verb == "send":
            msg = parse_send(text)  # checked before the bus is opened: the error names the field
            if not client.opened:
                raise ProtocolError("send before '< open BUS >'")
            self._relay(client, msg)
        elif verb == "open":
            self._open(client, words)
        elif verb == "rawmode":
            self._rawmode(client)
        elif verb == "echo":
            client.reply("< echo >")
        else:
            raise ProtocolError(f"unknown command {shown(verb)}")

    def _open(self, client: ClientLink, words: list[str]) -> None:
        """``< open BUS >``: any bus name will do (there is one bus), once per client."""
        if client.opened:
            raise ProtocolError("a bus is open already")
        if len(words) != 2 or len(words[1]) > _BUS_NAME:
            text = " ".join(words[1:])
            raise ProtocolError(f"open takes one bus name of up to {_BUS_NAME} characters: {shown(text)}")
        client.reply("< ok >")
        client.opened = True

    def _rawmode(self, client: ClientLink) -> None:
        """``< rawmode >``: ``< ok >``, then every frame; once per client."""
        if not client.opened:
            raise ProtocolError("rawmode before '< open BUS >'")
        if client.rawmode:
            raise ProtocolError("rawmode already")
        with self.lock:  # frames are queued under it: none before the ok (python-can reads it alone)
            client.rawmode = True
            with self._registry:
                self._clients = (*self._clients, client)
            client.put("< ok >")  # registered already when the client reads it

    def _relay(self, sender: ClientLink, msg: can.Message) -> None:
        """A client's frame: to the other clients and the devices, stamped when the server takes it."""
        with self.lock:  # one order of frames (and of stamps) for everyone; only queues are touched
            received = time.time()
            line = format_frame(msg, received)
            for client in self._clients:
                if client is not sender:
                    client.put(line)
            self.hub.clock = received  # the devices get the frame stamped when it came
            self.bus.send(msg)
