"""A bystander on the wire of a cross-process run: ``Watcher``, a second socketcand client of
``rig emulate`` that counts a drive's TPDOs and EMCYs and reads it by SDO once the host has let
go of it; ``LinkRelay``, a TCP relay between ``rig run`` and the emulator whose ``drop()`` cuts
the link as a pulled cable would; ``wait_for``, polling with a timeout that names what it waited
for. Used by ``rig faults`` (``rig.faults.wire``) and the tests across processes."""

from __future__ import annotations

import contextlib
import io
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import canopen
from canopen.objectdictionary import ODVariable

from drivers.bus import ReceiveWatch, open_bus
from drivers.cia402_units import discover_units
from drivers.maps import cia
from drivers.maps.cia import Mode, PowerState, decode_statusword

__all__ = ["LinkRelay", "Watcher", "wait_for"]


def wait_for(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    """Poll ``predicate`` every 10 ms; TimeoutError naming ``what`` after ``timeout`` [s].

    Parameters
    ----------
    predicate : Callable[[], bool]
        What is waited for.
    timeout : float
        [s].
    what : str
        Named in the error.

    Raises
    ------
    TimeoutError
        If it is not true within ``timeout``.
    """
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.01)


class Watcher:
    """A socketcand client of the emulator that counts the drive's frames and, once the host has
    let go of the node, reads it by SDO.

    Parameters
    ----------
    port : int
        The emulator's socketcand port.
    eds : Path
        The drive's EDS.
    node_id : int, optional
        The drive's node.
    """

    def __init__(self, port: int, eds: Path, node_id: int = 1) -> None:
        bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)
        self.network = canopen.Network(bus)
        self.network.connect()
        # the emulator killed under it (emulator-sigkill): logged once, not a dead receive thread
        assert self.network.notifier is not None  # connect() made it
        self.network.notifier.add_listener(ReceiveWatch())
        self.eds, self.node_id = eds, node_id
        self.tpdos = 0
        self.emcy: list[int] = []  #: EMCY error codes seen
        self._lock = threading.Lock()
        for n in range(4):
            self.network.subscribe(cia.COB_TPDO[n] + node_id, self._tpdo)
        self.network.subscribe(cia.COB_EMCY + node_id, self._emcy)
        self._node: Any = None

    def _tpdo(self, cob: int, data: bytearray, ts: float) -> None:
        with self._lock:
            self.tpdos += 1

    def _emcy(self, cob: int, data: bytearray, ts: float) -> None:
        code = int.from_bytes(data[:2], "little")
        if code:
            with self._lock:
                self.emcy.append(code)

    def _sdo(self) -> Any:
        if self._node is None:
            source = io.StringIO(self.eds.read_text(encoding="cp1252", errors="replace"))
            source.name = self.eds.name
            self._node = canopen.RemoteNode(self.node_id, canopen.import_od(source, self.node_id))
            self.network.add_node(self._node)
        return self._node

    def _read(self, index: int, subindex: int = 0) -> Any:
        node = self._sdo()
        try:
            obj = node.sdo[index]
            return obj.raw if isinstance(obj.od, ODVariable) else obj[subindex].raw
        except (KeyError, canopen.SdoAbortedError, canopen.SdoCommunicationError):
            return None

    def state(self) -> PowerState | None:
        """The drive's state by SDO (None: no answer).

        Returns
        -------
        PowerState | None
            Its state.
        """
        word = self._read(cia.STATUSWORD)
        return None if word is None else decode_statusword(word)

    def speed(self) -> float | None:
        """The drive's 0x606C [rad/s] (None: no answer).

        Returns
        -------
        float | None
            [rad/s].
        """
        raw = self._read(cia.VELOCITY_ACTUAL)
        if raw is None:
            return None
        units = discover_units(self._read, {}, where=f"node {self.node_id}", mode=Mode.CSV)
        return float(raw) / units.velocity

    def close(self) -> None:
        """Disconnect."""
        with contextlib.suppress(Exception):
            self.network.disconnect()


class LinkRelay:
    """A TCP relay between ``rig run`` and the emulator's socketcand port; ``drop()`` cuts it on
    both sides, as a pulled cable or a dead switch between two machines would. Its sockets have
    ``TCP_NODELAY``, as the host's and the emulator's: with Nagle's algorithm, a small write
    waited for the ACK of the one before, which the peer delays (40 ms on Linux), and the relay
    held the host's SYNCs and the drive's TPDOs about 40 ms every few dozen periods, a link no
    switch makes (the cycles after each hold acted on samples up to 20 periods old).

    Parameters
    ----------
    port : int
        The emulator's socketcand port.
    """

    def __init__(self, port: int) -> None:
        self._target = port
        self._server = socket.create_server(("127.0.0.1", 0))
        self.port: int = self._server.getsockname()[1]
        self._sockets: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._server.accept()
                upstream = socket.create_connection(("127.0.0.1", self._target))
            except OSError:
                return
            for s in (client, upstream):  # as both ends of the link: no write waits for an ACK
                s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._sockets += [client, upstream]
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pipe, args=(a, b), daemon=True).start()

    @staticmethod
    def _pipe(a: socket.socket, b: socket.socket) -> None:
        with contextlib.suppress(OSError):
            while data := a.recv(65536):
                b.sendall(data)

    def drop(self) -> None:
        """Cut the link on both sides."""
        self._server.close()
        for s in self._sockets:
            with contextlib.suppress(OSError):
                s.shutdown(socket.SHUT_RDWR)
            s.close()
