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

One thread (``thread``, named "socketcand") serves every client on non-blocking sockets
through one selector: accepting (a listen backlog of ``BACKLOG``: a burst of connections
waits for it, never for a SYN retransmitted a second later), reading, writing. No thread is
made per client, so a connection costs a few system calls, not thread starts under the
devices' clock. Every frame a client sends goes to the hub (the devices answer at once,
under their lock) and to the other clients; every frame the devices send goes to all
clients. Each client has its own bounded queue (``socketcand_link``): a client that does not
read is dropped, and no socket write waits with the devices' lock held. A device's answer to a
client's frame (the TPDOs answering its SYNC) goes to that client's kernel at once; every other
client gets its lines in one write a round, so a round costs a write per client however many
frames it carried (docs/emulator.md has what a write per frame and client cost). A client's
frames reach the bus in the order it sent them: they wait in one queue, and only the first of
them competes in arbitration.

The bus has a bit rate (``bitrate``, 1 Mbit/s by default): every frame, the devices' and the
clients', takes its time on it (``bus_time``: worst-case stuffing), and a client's frame waits
until the bus has room, so a client that sends faster than the bus carries is held back (its
commands stay in its socket, and TCP holds its writes) as a CAN controller's transmit queue
holds it on a real bus, and a reader's queue never fills faster than the bus rate. Of the
frames waiting, the one with the lowest identifier goes first, as arbitration has it (a flood
of high identifiers leaves the bus to an SDO request; one of low identifiers would hold it off,
as on a real bus, but never faster than the bit rate).

Timestamps are wall-clock seconds (time.time(), as socketcand stamps frames): a device frame
carries the moment it was sent, a client's frame the moment the server took it, which is also
the ``hub.clock`` the devices see it at.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import selectors
import socket
import threading
import time
from collections.abc import Callable

import can

from drivers.bus_time import DEFAULT_BITRATE, BusTime
from plant_emulator.lockstep import SyncHub
from plant_emulator.socketcand_commands import ClientCommands
from plant_emulator.socketcand_link import ClientLink, check_limits
from plant_emulator.socketcand_protocol import MAX_COMMAND, CommandTooLong, format_frame, parse_send

__all__ = ["BACKLOG", "MAX_COMMAND", "SocketcandServer", "format_frame", "parse_send"]

log = logging.getLogger(__name__)

_CHUNK = 65536  #: [bytes] read at a time
BACKLOG = 1024  #: connections the kernel holds until they are accepted
_LOOK = 0.25  #: [s] how often a client whose kernel buffer is full is looked at again


class SocketcandServer:
    """Serve ``hub`` on TCP ``host``:``port`` until ``stop``.

    Parameters
    ----------
    hub : SyncHub
        The emulated bus.
    lock : threading.RLock
        The devices' lock.
    host, port : str and int, optional
        The address served (port 0: any free port; see ``port``).
    queue_depth : int, optional
        Lines each client may have waiting.
    send_timeout : float, optional
        [s] for the kernel to take any of them.
    send_buffer : int | None, optional
        [bytes] the kernel's send buffer of each client socket (None: the system's).
    bitrate : float, optional
        [bit/s] the bus's.
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
        bitrate: float = DEFAULT_BITRATE,
    ):
        check_limits(queue_depth, send_timeout)
        self.hub = hub
        self.lock = lock
        self.queue_depth, self.send_timeout, self.send_buffer = queue_depth, send_timeout, send_buffer
        self.bus_time = BusTime(bitrate)  #: the bus's time, booked under ``lock``
        self._clients: tuple[ClientLink, ...] = ()  #: in rawmode: they get every frame
        self._links: set[ClientLink] = set()  #: every client connected (the I/O thread's)
        self._dirty: collections.deque[ClientLink] = collections.deque()  #: links with lines to send
        self._signalled = False  #: the I/O thread has been woken and not yet looked
        self.commands = ClientCommands(self._put, self._rawmode)  #: what the clients' commands do
        self._sender: ClientLink | None = None  #: the client whose frame the devices answer now
        self._stopping = threading.Event()
        self.accepted = 0  #: connections accepted so far
        #: called by the I/O thread after each round of serving and sending, before it waits again
        #: (its slack: a SYNC's answers are out by then); the emulator collects garbage there
        self.idle: Callable[[], object] | None = None
        self.bus = hub.bus(queue=False, channel="socketcand")
        self.bus.listeners.append(self._to_clients)
        try:
            self._listener = socket.create_server((host, port), backlog=BACKLOG)
        except OSError:
            self.bus.shutdown()  # nothing is served: the hub's bus goes too, not left to the collector
            raise
        self._listener.setblocking(False)
        self.port = int(self._listener.getsockname()[1])
        self._wake_in, self._wake_out = socket.socketpair()
        self._wake_in.setblocking(False)
        self._wake_out.setblocking(False)
        self._selector = selectors.DefaultSelector()
        self._selector.register(self._listener, selectors.EVENT_READ)
        self._selector.register(self._wake_in, selectors.EVENT_READ)
        self.thread = threading.Thread(target=self._run, name="socketcand", daemon=True)

    @property
    def client_count(self) -> int:
        """Clients in rawmode now."""
        return len(self._clients)

    def start(self) -> None:
        """Serve from the server's thread."""
        self.thread.start()
        log.info("socketcand rawmode server on %s:%d", *self._listener.getsockname()[:2])

    def stop(self) -> None:
        """Close every client and the listening socket (a server never started too)."""
        self._stopping.set()
        if self.thread.is_alive():
            self._wake()
            self.thread.join()
        else:
            self._close_all()
        self.bus.shutdown()

    # --- from any thread ------------------------------------------------------------------

    def _wake(self) -> None:
        """Tell the I/O thread to look (once until it does)."""
        if self._signalled or threading.get_ident() == self.thread.ident:
            return
        self._signalled = True
        with contextlib.suppress(OSError):  # full: it is awake already; closed: it has stopped
            self._wake_out.send(b"\0")

    def _put(self, client: ClientLink, line: str) -> None:
        if not client.put(line):
            self._dirty.append(client)
            self._wake()

    def _to_clients(self, msg: can.Message) -> None:
        """A device's frame (called under the devices' lock): on the bus now, queued for every
        client, stamped now. A device answering a client's frame (on the I/O thread, in
        ``_relay``: the TPDOs answering a SYNC) has it handed to that client's kernel at once, as
        socketcand writes each frame as it comes, not after the devices' other work on that SYNC
        (a non-blocking write, never a wait: what the kernel does not take waits in the queue as
        any line does); the other clients get it with the round's writes (``_send``)."""
        now = time.monotonic()
        self.bus_time.carry(msg, now)
        line = format_frame(msg, time.time())
        for client in self._clients:
            self._put(client, line)
        sender = self._sender  # (set only by the I/O thread, and only while it relays a frame)
        if sender is not None and threading.get_ident() == self.thread.ident and not sender.closed:
            sender.send(now)

    # --- the I/O thread ---------------------------------------------------------------------

    def _run(self) -> None:
        try:
            while not self._stopping.is_set():
                for key, events in self._selector.select(self._timeout()):
                    if key.fileobj is self._listener:
                        self._accept()
                    elif key.fileobj is self._wake_in:
                        self._signalled = False
                        with contextlib.suppress(OSError):
                            self._wake_in.recv(4096)
                    elif events & selectors.EVENT_READ:
                        self._receive(key.data)
                self._serve()
                self._send()
                if self.idle is not None:
                    self.idle()
        finally:
            self._close_all()

    def _timeout(self) -> float | None:
        """How long the selector may wait: until the bus has room for a waiting command, or a
        stuck client is looked at again; for ever when nothing waits."""
        waits = []
        if any(c.commands and not c.crowded for c in self._links):
            waits.append(self.bus_time.wait(time.monotonic()))
        if any(c.unsent for c in self._links):
            waits.append(_LOOK)
        return min(waits) if waits else None

    def _accept(self) -> None:
        """Every connection waiting: non-blocking, greeted, registered for reading."""
        while True:
            try:
                sock, _ = self._listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # out of descriptors: the rest wait in the backlog
                log.warning("socketcand: cannot accept a connection: %s", exc)
                return
            self.accepted += 1
            sock.setblocking(False)
            with contextlib.suppress(OSError):  # a client gone already: its first recv says so
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                if self.send_buffer is not None:
                    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.send_buffer)
            client = ClientLink(sock, depth=self.queue_depth, send_timeout=self.send_timeout)
            self._links.add(client)
            client.events = selectors.EVENT_READ
            self._selector.register(sock, client.events, client)
            self._put(client, "< hi >")

    def _receive(self, client: ClientLink) -> None:
        """What ``client`` sent, cut into commands (done by ``_serve``)."""
        try:
            chunk = client.sock.recv(_CHUNK)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop(client, None)
            return
        if not chunk:
            client.eof = True
            self._drop(client, None)
            return
        try:
            client.commands.extend(client.splitter.feed(chunk))
        except CommandTooLong as exc:
            client.commands.clear()
            self._put(client, f"< error {exc} >")
            client.send(time.monotonic())  # the error goes out if the kernel takes it now
            self._drop(client, str(exc))

    def _serve(self) -> None:
        """The clients' commands. What needs no bus is done at once; a frame waits until the bus
        has room, and of the frames waiting the one CAN arbitration lets through goes first
        (``socketcand_commands.arbitration``: the lowest identifier; equal ones in the order they
        came to wait), each client's own in their order. A client whose queue is crowded or whose
        commands wait is not read (TCP holds its sender)."""
        while True:
            waiting = [c for c in self._links if self.commands.advance(c)]
            if not waiting or self.bus_time.wait(time.monotonic()) > 0.0:
                break
            first = min(waiting, key=lambda c: c.head_key)
            msg, first.head = first.head, None
            first.commands.popleft()
            assert msg is not None
            self._relay(first, msg)
        for client in list(self._links):
            self._listen(client)

    def _listen(self, client: ClientLink) -> None:
        """Register ``client`` for what it needs now: reading once its commands are done."""
        if client.closed:
            return
        events = 0 if client.commands or client.crowded else selectors.EVENT_READ
        events |= selectors.EVENT_WRITE if client.unsent else 0
        if events == client.events:
            return
        if client.events:
            if events:
                self._selector.modify(client.sock, events, client)
            else:
                self._selector.unregister(client.sock)
        else:
            self._selector.register(client.sock, events, client)
        client.events = events

    def _send(self) -> None:
        """What is queued to every client with lines or unsent bytes; the doomed dropped."""
        now = time.monotonic()
        while self._dirty:
            client = self._dirty.popleft()
            client.dirty = False
            client.send(now)
        for client in list(self._links):
            if client.unsent:
                client.send(now)
            if client.doomed is not None:
                self._drop(client, client.doomed)
            else:
                self._listen(client)

    def _drop(self, client: ClientLink, reason: str | None) -> None:
        if client.closed:
            return
        if client.events:
            self._selector.unregister(client.sock)
            client.events = 0
        self._links.discard(client)
        if client.rawmode:
            with self.lock:  # the devices' thread reads the tuple under it
                self._clients = tuple(c for c in self._clients if c is not client)
        client.close(reason)

    def _close_all(self) -> None:
        for client in list(self._links):
            self._drop(client, None)
            log.info("socketcand: client %s closed: the server stops", client.name)
        self._selector.close()
        for sock in (self._listener, self._wake_in, self._wake_out):
            sock.close()

    # --- commands -----------------------------------------------------------------------------

    def _rawmode(self, client: ClientLink) -> None:
        """``< rawmode >``: ``< ok >``, then every frame."""
        self._put(client, "< ok >")
        client.send(time.monotonic())  # alone, before any frame: python-can's client reads it alone
        with self.lock:  # frames are queued under it: from now on, after the ok
            client.rawmode = True
            self._clients = (*self._clients, client)

    def _relay(self, sender: ClientLink, msg: can.Message) -> None:
        """A client's frame: on the bus, to the other clients and the devices, stamped when the
        server takes it."""
        with self.lock:  # one order of frames (and of stamps) for everyone; only queues are touched
            self.bus_time.carry(msg, time.monotonic())
            received = time.time()
            others = [client for client in self._clients if client is not sender]
            if others:
                line = format_frame(msg, received)
                for client in others:
                    self._put(client, line)
            self.hub.clock = received  # the devices get the frame stamped when it came
            self._sender = sender  # the devices' answers go to it at once (``_to_clients``)
            try:
                self.bus.send(msg)
            finally:
                self._sender = None
