"""An emulated CANopen device (CiA 301) on canopen's ``LocalNode``.

canopen's LocalNode gives the SDO server, the NMT state variable and the EMCY
producer. What a real device also does, and LocalNode does not, is written
here once: boot-up and the two NMT resets, gating of SDO/PDO/SYNC/EMCY by the
NMT state, a heartbeat producer driven by the device's clock (emulated time
in lock-step, so traces repeat), a SYNC consumer, TPDOs packed from the object
dictionary (synchronous every n-th SYNC, or event-driven on change and on the
event timer), and RPDOs unpacked into the object dictionary (at the next SYNC
for synchronous types 0-240, on receipt for 254/255: ``plant_emulator.pdo_exchange``).
PDO communication and mapping parameters (0x1400-0x1BFF) are read from the object
dictionary, so a remap written through SDO takes effect at the next use.

NMT gating (CiA 301, 7.3.2): PRE-OPERATIONAL: SDO, SYNC, EMCY, heartbeat;
OPERATIONAL: all; STOPPED: NMT and heartbeat only. In lock-step a SYNC is also
the step of emulated time: the device's own work (its physics and control)
goes on in every NMT state; only the PDOs are gated.

Supervision (``plant_emulator.supervision``): the heartbeat consumer 0x1016 and
the RPDO deadlines (event timer of an RPDO). A loss is a communication error:
EMCY 0x8130 (heartbeat) or 0x8250 (RPDO timeout), the NMT state 0x1029 sub 1
selects (where the device has 0x1029), and the ``on_abort_connection`` hook (a
drive's 0x6007). NMT stop or pre-operational of an OPERATIONAL node calls the
hook too: the PDOs that carried its set-points have stopped.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Callable
from typing import Any

import canopen
from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
from drivers.maps.cia import (
    BOOT_UP,
    COB_HEARTBEAT,
    COB_ID_MASK,
    COB_NMT,
    COMMUNICATION_AREA,
    PDO_BLOCK,
    EmcyCode,
    NmtCommand,
    NmtState,
    SdoAbortCode,
)
from drivers.maps.od import load_od
from plant_emulator.device_hooks import DeviceHooks
from plant_emulator.frame import Frame
from plant_emulator.lss_slave import UNCONFIGURED, check_node_id, lss_slave
from plant_emulator.od_store import ObjectStore, StoreNode
from plant_emulator.param_store import ParameterStore
from plant_emulator.pdo import MAPPINGS, PARAMETERS, PdoConfig, check_mapping_write
from plant_emulator.pdo_exchange import PdoExchange
from plant_emulator.sdo_server import SdoServer
from plant_emulator.supervision import Deadlines, HeartbeatConsumer, Supervision, check_consumer_entry

__all__ = ["EmulatedNode", "PdoConfig"]

log = logging.getLogger(__name__)

#: NMT states as the plain ints canopen's NmtSlave keeps (compared on every frame)
PRE_OPERATIONAL, OPERATIONAL, STOPPED, INITIALISING = (
    int(NmtState.PRE_OPERATIONAL),
    int(NmtState.OPERATIONAL),
    int(NmtState.STOPPED),
    int(NmtState.INITIALISING),
)
_SDO_SYNC_STATES = (PRE_OPERATIONAL, OPERATIONAL)
RPDO_COMMS = range(cia.RPDO_COMM, cia.RPDO_COMM + PDO_BLOCK)  #: the RPDOs' communication parameters


class EmulatedNode(Supervision, DeviceHooks):
    """A CiA 301 slave on ``network`` built from the EDS at ``eds``.

    Devices override its hooks (``plant_emulator.device_hooks``): ``on_sync_latch`` updates the
    process data before the synchronous TPDOs go out, ``on_rpdo``, ``on_reset``, ...

    Parameters
    ----------
    node_id : int
        Its node-ID (255: none yet, LSS only).
    eds : str
        Its EDS.
    network : canopen.Network
        The canopen network it answers on.
    """

    def __init__(self, node_id: int, eds: str, network: canopen.Network) -> None:
        self.node_id = check_node_id(node_id)
        net: Any = network  # canopen's callback types say bytearray; frames are bytes
        local: Any = StoreNode(node_id, load_od(eds, node_id))
        local.sdo = SdoServer(local.sdo.rx_cobid, local.sdo.tx_cobid, local)  # CiA 301's end of a transfer
        self.network: Any = net
        self.node: Any = local
        self.od = ObjectStore(local)  #: typed, cached device-side access to the object dictionary
        self.network.add_node(self.node)
        self._gate()
        self.params = ParameterStore(local.object_dictionary, self.od.raw, lambda: self._power_on)
        self.lss = lss_slave(self)  #: CiA 305, where its EDS says so or it has no node-ID yet
        self.node.on_stored = self._store_watch()
        self.fixed_mapping = False  #: the PDO mappings refuse every write (SDO abort 0x06010002)
        self.clock = 0.0  #: device time [s]
        #: real time: the emulator's monotonic clock [s]; None: time is the SYNCs' (lock-step)
        self.clock_source: Callable[[], float] | None = None
        self.sdo_delay = 0.0  #: [s] real time: an SDO request is answered this long after it came
        self._deferred: list[tuple[float, int, bytes, float]] = []  #: (due [s], COB-ID, data, stamp)
        self._last_heartbeat = -1e9
        self.pdos = PdoExchange(self, self._send)  #: its TPDOs and RPDOs
        self._sync_cob: int | None = None
        self._dirty = True
        self.heartbeats = HeartbeatConsumer()  #: 0x1016
        self.rpdo_deadlines = Deadlines()  #: RPDO number -> event timer
        self._consumed: list[int] = []  #: COB-IDs of the heartbeats consumed
        self.rx_time = 0.0  #: timestamp [s] of the RPDO being handled
        self.in_rpdo = False  #: an RPDO's data are being written (``on_write`` sees its objects)
        self._power_on: dict[int, dict[int, bytes]] | None = None

    def _gate(self) -> None:
        """canopen's LocalNode rewired: SDO and NMT through our gates, the heartbeat on our clock
        (not canopen's thread), every write seen by ``_on_write``."""
        # SDO and NMT through our gates; heartbeat on our clock, not canopen's thread
        self.network.unsubscribe(self.node.sdo.rx_cobid, self.node.sdo.on_request)
        self.network.subscribe(self.node.sdo.rx_cobid, self._on_sdo)
        # NMT through a gate as well: CiA 301 NMT frames are exactly 2 bytes
        self.network.unsubscribe(COB_NMT, self.node.nmt.on_command)
        self.network.subscribe(COB_NMT, self._on_nmt)
        nmt: Any = self.node.nmt
        nmt.start_heartbeat = lambda ms: None
        nmt.stop_heartbeat = lambda: None
        nmt.update_heartbeat = lambda: None
        self.node._write_callbacks.remove(nmt.on_write)  # it only (re)starts that heartbeat thread
        self.node.add_write_callback(self._on_write)

    def _store_watch(self) -> Callable[[int, int], None]:
        """What the store calls for every object stored: the cached value dropped, a signature not
        kept, the heartbeat watch and an RPDO's deadline changed at once, ``after_write``."""
        cached = self.od.values  # what ObjectStore.forget drops, without its call per object stored

        def stored(index: int, subindex: int) -> None:
            cached.pop((index, subindex), None)
            if self.params.handles(index):  # a signature is a command, not a value to keep
                self.node.data_store.get(index, {}).pop(subindex, None)
            if index == cia.CONSUMER_HEARTBEAT:  # the watch changes at once, not at the next SYNC
                self._configure_consumer()
            elif index in RPDO_COMMS and subindex == cia.PDO_COMM_EVENT_TIMER:  # so does a deadline
                self._configure()
            self.after_write(index)

        return stored

    # --- NMT -----------------------------------------------------------
    @property
    def nmt_state(self) -> int:
        return self.node.nmt._state  # type: ignore[no-any-return]

    def boot(self) -> None:
        """Power on: INITIALISING, boot-up, PRE-OPERATIONAL (``_start``); the dictionary as it is now
        is what the NMT resets restore until parameters are stored (``plant_emulator.param_store``)."""
        if self._power_on is None:
            self._power_on = self.params.power_on(self.node.data_store)
        self.node.nmt._state = INITIALISING
        self.on_reset(application=True)
        self._start()
        self._last_heartbeat = self.clock

    def _start(self) -> None:  # boot-up, PRE-OPERATIONAL; without a node-ID INITIALISING (LSS only)
        self._dirty = True
        if self.node_id != UNCONFIGURED:
            self._send(COB_HEARTBEAT + self.node_id, bytes([BOOT_UP]))
            self.node.nmt._state = PRE_OPERATIONAL
        self._configure()

    def _on_nmt(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self.node_id == UNCONFIGURED:  # no NMT slave until it has a node-ID (CiA 305)
            return
        if len(data) != 2:
            log.warning("node %d: NMT frame of %d bytes ignored", self.node_id, len(data))
            return
        before = self.nmt_state
        self.node.nmt.on_command(can_id, data, timestamp)
        self._after_nmt(can_id, data, timestamp)
        if before == OPERATIONAL and self.nmt_state in (STOPPED, PRE_OPERATIONAL):
            state = NmtState(self.nmt_state).text
            self.on_abort_connection(f"NMT {state} while OPERATIONAL", EmcyCode.COMMUNICATION)

    def _after_nmt(self, can_id: int, data: bytes, timestamp: float) -> None:
        cmd, target = struct.unpack_from("BB", data)
        if target not in (0, self.node_id):
            return
        if cmd in (NmtCommand.RESET_NODE, NmtCommand.RESET_COMMUNICATION):
            self.reset(comm_only=cmd == NmtCommand.RESET_COMMUNICATION)
        self._configure()

    def reset(self, *, comm_only: bool = False) -> None:
        """NMT reset node (or communication): the node-ID pending (LSS), power-on values, boot-up.

        Parameters
        ----------
        comm_only : bool, optional
            Reset communication (else reset node).
        """
        if self.lss is not None:
            self.lss.on_reset(application=not comm_only)
        stored = self._power_on or {}
        for index in list(self.node.data_store):
            if not comm_only or index in COMMUNICATION_AREA:
                del self.node.data_store[index]
        for index, subs in stored.items():
            if not comm_only or index in COMMUNICATION_AREA:
                self.node.data_store[index] = dict(subs)
        self.od.clear()
        log.info("node %d: NMT %s", self.node_id, "reset communication" if comm_only else "reset node")
        self.node.nmt._state = INITIALISING
        if not comm_only:
            self.on_reset(application=True)
        self._start()

    def tick(self, now: float) -> None:
        """Advance the device clock to ``now`` [s]: heartbeat and event timers.

        Parameters
        ----------
        now : float
            [s] the device clock.
        """
        self.clock = now
        if self._deferred:
            self._answer_sdo(now)
        nmt = self.node.nmt
        period = self.od.read(cia.PRODUCER_HEARTBEAT, 0) / 1000.0  # ms -> s
        if period > 0.0 and now - self._last_heartbeat >= period - 1e-9 and nmt._state != INITIALISING:
            self._last_heartbeat = now
            self._send(COB_HEARTBEAT + self.node_id, bytes([nmt._state]))
        if nmt._state == OPERATIONAL:
            self.event_tpdos(now)
        self.supervise(now)

    def event_tpdos(self, now: float) -> None:
        """TPDOs of type 254/255: sent when their data change or their event timer (sub 5) expires.

        Parameters
        ----------
        now : float
            [s] the device clock.
        """
        self.pdos.send_events(now)

    # --- SDO -------------------------------------------------------------
    def _on_sdo(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self.nmt_state not in _SDO_SYNC_STATES:
            return
        if self.sdo_delay > 0.0 and self.clock_source is not None:  # real time: answer later
            self._deferred.append((self.clock_source() + self.sdo_delay, can_id, bytes(data), timestamp))
            return
        self.node.sdo.on_request(can_id, data, timestamp)

    def _answer_sdo(self, now: float) -> None:
        """The SDO requests whose response time has passed, in order (real time)."""
        while self._deferred and self._deferred[0][0] <= now:
            _, can_id, data, timestamp = self._deferred.pop(0)
            if self.nmt_state in _SDO_SYNC_STATES:
                self.node.sdo.on_request(can_id, data, timestamp)

    def _on_write(self, index: int, subindex: int, od: Any, data: bytes) -> None:
        if index in PARAMETERS:
            if self.fixed_mapping and any(index in r for r in MAPPINGS):
                raise SdoAbortedError(SdoAbortCode.READ_ONLY)
            check_mapping_write(self.od, index, subindex, data)
            self._dirty = True
        if index == cia.CONSUMER_HEARTBEAT and subindex:
            check_consumer_entry(self._consumer_entries(), subindex, int.from_bytes(data, "little"))
            self._dirty = True
        if index == cia.COB_ID_SYNC:
            self._dirty = True
        if self.params.handles(index):  # 0x1010/0x1011: into (from) the image a reset restores
            self.params.on_write(index, subindex, bytes(data))
        self.on_write(index, subindex, data)

    # --- object dictionary access ----------------------------------------
    def _u(self, index: int, subindex: int) -> int:
        """Value of an unsigned object (a count, a COB-ID, a time)."""
        return self.od.read(index, subindex)  # type: ignore[no-any-return]

    def read(self, index: int, subindex: int = 0) -> Any:
        """Decoded value of an object.

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        Any
            Its value.
        """
        return self.od.read(index, subindex)

    def write(self, index: int, subindex: int, value: Any) -> None:
        """Set an object's value from the device side (no access check, no write callbacks; the
        device takes note, as of any stored write: ``after_write``).

        Parameters
        ----------
        index, subindex : int
            The object.
        value : Any
            Its value.
        """
        self.od.write(index, subindex, value)
        self.after_write(index)

    # --- PDO -------------------------------------------------------------
    def _send(self, cob_id: int, data: bytes) -> None:
        """A frame from this node (on the bus directly: canopen's ``send_message`` adds a lock
        and a check that cost a third of the frame, and the devices are driven by one thread)."""
        bus = self.network.bus
        if bus is None:
            raise RuntimeError("Not connected to CAN bus")
        bus.send(Frame(cob_id, data))

    def _configure(self) -> None:
        if not self._dirty:
            return
        self._dirty = False
        self.pdos.configure()
        self._configure_consumer()
        sync_cob = self._u(cia.COB_ID_SYNC, 0) & COB_ID_MASK
        if sync_cob != self._sync_cob:
            if self._sync_cob is not None:
                self.network.unsubscribe(self._sync_cob, self._on_sync)
            self.network.subscribe(sync_cob, self._on_sync)
            self._sync_cob = sync_cob

    def _on_sync(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self._dirty:
            self._configure()
        self.on_sync_latch(timestamp)  # the device's work: in every NMT state (lock-step's time step)
        now = self.sync_time(timestamp)
        state = self.node.nmt._state  # read where it counts, as it may change meanwhile
        if state in _SDO_SYNC_STATES:
            self.pdos.on_sync(operational=state == OPERATIONAL)
        self.tick(now)

    def emcy(self, code: int, register: int, data: bytes = b"") -> None:
        """Send an EMCY (in PRE-OPERATIONAL and OPERATIONAL) and set 0x1001.

        Parameters
        ----------
        code : int
            The emergency error code.
        register : int
            0x1001, the error register.
        data : bytes, optional
            Manufacturer-specific bytes (up to 5).
        """
        self.write(cia.ERROR_REGISTER, 0, register)
        if self.nmt_state in _SDO_SYNC_STATES:
            self.node.emcy.send(code, register, data)
