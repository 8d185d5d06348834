"""The PDO exchange of an emulated CANopen node (CiA 301): its TPDOs packed from the object
dictionary and sent, its RPDOs unpacked into it.

The PDOs are as the node's communication and mapping parameters (0x1400-0x1BFF) say at the last
``PdoExchange.configure`` (the node calls it when one of them was written, so a remap through SDO
takes effect at the next use). TPDOs of types 1-240 go out every n-th SYNC, those of types
254/255 when their data change or their event timer (sub 5) expires; an RPDO of types 0-240 is
applied at the next SYNC, one of 254/255 on receipt. The node
(``plant_emulator.canopen_node.EmulatedNode``) gates them by its NMT state: it calls
``on_sync`` in PRE-OPERATIONAL and OPERATIONAL, ``send_events`` in OPERATIONAL; an RPDO is taken
in OPERATIONAL only.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from drivers.maps.cia import PDO_SYNC_MAX, EmcyCode, ErrorRegister, NmtState
from plant_emulator.pdo import PdoConfig, PdoTables, pack, read_pdos

__all__ = ["PdoExchange"]

log = logging.getLogger(__name__)

OPERATIONAL = int(NmtState.OPERATIONAL)  #: as canopen's NmtSlave keeps it (compared on every frame)


class PdoExchange:
    """The PDOs of ``node``, sent with ``send``; see the module docstring.

    Parameters
    ----------
    node : Any
        The ``EmulatedNode`` whose PDOs they are: its object dictionary, its network, its hooks
        (``on_rpdo``), its EMCY and its RPDO deadlines.
    send : Callable[[int, bytes], None]
        Sends a frame (COB-ID, data) from the node.
    """

    def __init__(self, node: Any, send: Callable[[int, bytes], None]) -> None:
        self.node = node
        self.send = send
        #: the PDOs as the dictionary configured them at the last ``configure``
        self.tables = PdoTables([], [], [], [], {})
        self._subscribed: list[int] = []  #: the RPDOs' COB-IDs subscribed to
        self._sync_count = 0  #: SYNCs counted (PRE-OPERATIONAL and OPERATIONAL)
        self._pending_sync_rpdo: dict[int, bytes] = {}  #: RPDO number -> data for the next SYNC
        self._last_event: dict[int, bytes] = {}  #: TPDO number -> the data it last sent
        self._last_event_time: dict[int, float] = {}  #: TPDO number -> [s] when it last sent

    def configure(self) -> None:
        """Read the PDOs from the dictionary, subscribe to the valid RPDOs' COB-IDs and set their
        deadlines (the event timer of each, ms -> s)."""
        node = self.node
        self.tables = read_pdos(node.od, node.node.object_dictionary)
        for cob in self._subscribed:
            node.network.unsubscribe(cob, self.on_frame)
        self._subscribed = list(self.tables.rpdo_of_cob)
        for cob in self._subscribed:
            node.network.subscribe(cob, self.on_frame)
        node.rpdo_deadlines.configure(
            {p.number: p.event_timer_ms / 1000.0 for p in self.tables.rpdo_of_cob.values()}  # ms -> s
        )

    def on_frame(self, can_id: int, data: bytes, timestamp: float) -> None:
        """An RPDO's frame (OPERATIONAL only): its deadline fed, its data applied now or at the
        next SYNC; one of another length than its mapping is not processed (EMCY 0x8210/0x8220).

        Parameters
        ----------
        can_id : int
            Its COB-ID.
        data : bytes
            Its data.
        timestamp : float
            [s] when it came.
        """
        node = self.node
        if node.node.nmt._state != OPERATIONAL:
            return
        node.rx_time = timestamp
        try:
            pdo = self.tables.rpdo_of_cob[can_id]
        except KeyError:
            return
        if len(data) != pdo.size:  # CiA 301: not processed, EMCY 0x8210 (too short) / 0x8220 (too long)
            log.warning(
                "node %d: RPDO%d with %d bytes, mapped %d: ignored",
                node.node_id,
                pdo.number + 1,
                len(data),
                pdo.size,
            )
            code = EmcyCode.PDO_TOO_SHORT if len(data) < pdo.size else EmcyCode.PDO_TOO_LONG
            node.emcy(code, ErrorRegister.GENERIC | ErrorRegister.COMMUNICATION)
            return  # nor is it the master alive: the RPDO's deadline is not fed by it
        if pdo.number in node.rpdo_deadlines.times:
            node.rpdo_deadlines.heard(pdo.number, node.heard_now())
        if pdo.ttype <= PDO_SYNC_MAX:
            self._pending_sync_rpdo[pdo.number] = bytes(data)
        else:
            self.unpack(pdo, bytes(data))
            node.on_rpdo(pdo.number, synchronous=False)

    def unpack(self, pdo: PdoConfig, data: bytes) -> None:
        """Write an RPDO's data into the mapped objects, as an SDO write would (callbacks first;
        the node's ``in_rpdo`` is True meanwhile).

        Parameters
        ----------
        pdo : PdoConfig
            The RPDO.
        data : bytes
            Its data.
        """
        node = self.node
        if len(data) < pdo.size:
            log.warning("node %d: RPDO%d shorter than its mapping", node.node_id, pdo.number + 1)
            return
        store, obj = node.node.store, node.od.obj
        node.in_rpdo = True
        try:
            for index, sub, start, end in pdo.slices:
                store(index, sub, obj(index, sub), data[start:end])
        finally:
            node.in_rpdo = False

    def on_sync(self, *, operational: bool) -> None:
        """A SYNC in PRE-OPERATIONAL or OPERATIONAL: counted; in OPERATIONAL the synchronous TPDOs
        whose turn it is sent, then the RPDOs received since the last SYNC applied, in order.

        Parameters
        ----------
        operational : bool
            The node is OPERATIONAL.
        """
        self._sync_count += 1
        if not operational:
            return
        send, od = self.send, self.node.od
        for pdo in self.tables.sync_tpdos:
            if self._sync_count % pdo.ttype == 0:
                send(pdo.cob_id, pack(od, pdo))
        if self._pending_sync_rpdo:
            pending, self._pending_sync_rpdo = self._pending_sync_rpdo, {}
            rpdos = {p.number: p for p in self.tables.rpdos}
            for number, payload in sorted(pending.items()):
                self.unpack(rpdos[number], payload)
                self.node.on_rpdo(number, synchronous=True)

    def send_events(self, now: float) -> None:
        """The TPDOs of type 254/255 whose data changed or whose event timer expired, sent.

        Parameters
        ----------
        now : float
            [s] the device clock.
        """
        for pdo in self.tables.event_tpdos:
            payload = pack(self.node.od, pdo)
            last = self._last_event.get(pdo.number)
            timer = pdo.event_timer_ms / 1000.0
            due = timer > 0.0 and now - self._last_event_time.get(pdo.number, -1e9) >= timer - 1e-9
            if payload != last or due:
                self._last_event[pdo.number] = payload
                self._last_event_time[pdo.number] = now
                self.send(pdo.cob_id, payload)
