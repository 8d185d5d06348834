"""What every CANopen axis shares: one node on a canopen ``RemoteNode``, with the toolkit's errors.

``CanopenAxis`` gives its subclasses (the CiA 402 drive, the CiA 406 encoder)
SDO access that raises ``SdoAbort``/``CommunicationTimeout`` naming the node and
object, NMT commands, the EMCY consumer (an EMCY with a non-zero code becomes
the axis's ``fault``), and the per-cycle supervision of NMT state, heartbeat
and EMCY. Process data are received by ``drivers.tpdo_slot.TpdoSlot`` (re-exported
here with ``pdo_codec`` and ``sample_interval``).
"""

from __future__ import annotations

import contextlib
import logging
import struct
from collections.abc import Sequence
from typing import Any, ClassVar

import canopen
from canopen.emcy import EmcyError
from canopen.sdo.base import SdoVariable

from drivers.base import AxisDriver
from drivers.errors import CommunicationError, DeviceFault, SafetyStop, brief
from drivers.identity import Identity, check_identity, read_identity
from drivers.maps import cia
from drivers.maps.emcy import emcy_text
from drivers.maps.logical import axis_dictionary, axis_object
from drivers.maps.od import load_od
from drivers.master_watch import MasterWatch, OtherMaster
from drivers.producer_watch import OtherProducer, ProducerWatch
from drivers.sdo_answer import sized
from drivers.sdo_errors import sdo_errors
from drivers.tpdo_slot import TpdoSlot, pdo_codec, sample_interval

__all__ = ["CanopenAxis", "TpdoSlot", "pdo_codec", "sample_interval"]

log = logging.getLogger(__name__)

#: EMCY codes of a PDO not processed for its length (CiA 301: too short, too long)
_PDO_LENGTH = frozenset({cia.EmcyCode.PDO_TOO_SHORT, cia.EmcyCode.PDO_TOO_LONG})


class CanopenAxis(AxisDriver):
    """An axis on CANopen node ``node_id`` of ``network``, described by the EDS/DCF ``eds``
    (``eds_given``: the device's own, given by the user; else the toolkit's, used as a generic
    dictionary of the profile's standard objects); ``axis``: which of the device's logical
    devices (``drivers.maps.logical``: its objects 0x800 (axis - 1) above axis 1's, which are
    the indices this class and its subclasses name). Axes of one node share the node's
    communication objects; each has its own canopen ``RemoteNode`` on the network (the first on
    its node id holds ``network[node_id]``)."""

    sample_name, wall_stamps = "TPDO", True  #: a TPDO's stamp: its frame's receive time
    #: how the user gives the device's own EDS (``rig drive`` says ``--eds FILE``)
    eds_hint = 'the axis\'s eds = "FILE"'
    #: SDO response timeout [s] and retries; a test may override them
    SDO_TIMEOUT = 0.3
    SDO_RETRIES = 1
    #: the axes alive on each (network, node id): the axes of one device (``siblings``)
    _ON_NODE: ClassVar[dict[tuple[int, int], list[CanopenAxis]]] = {}

    def __init__(
        self,
        name: str,
        mode: str | None,
        network: canopen.Network,
        node_id: int,
        *,
        eds: str,
        eds_given: bool = True,
        heartbeat_timeout: float = 0.0,
        sdo_timeout: float | None = None,
        sdo_retries: int | None = None,
        axis: int = 1,
    ) -> None:
        """``sdo_timeout`` [s] and ``sdo_retries``: of every SDO transfer (None: the class's)."""
        super().__init__(name, mode)
        if not 1 <= node_id <= 127:
            self._forget()
            raise ValueError(f"axis {name!r}: node id must be 1..127, got {node_id!r}")
        self.node_id = node_id
        self.eds = eds
        #: ``eds`` is the device's own (given by the user), not the toolkit's generic dictionary
        self.eds_given = eds_given
        self.heartbeat_timeout = heartbeat_timeout  #: [s]; 0: not supervised
        self.network = network
        self.device_id = Identity()  #: 0x1018 as read at set-up (``check_identity``)
        try:
            od = axis_dictionary(load_od(eds, node_id), axis, source=str(eds), generic=not eds_given)
        except BaseException:
            self._forget()  # nothing was opened: not an unclosed axis
            raise
        self.eds = str(eds)  #: the EDS/DCF file of the dictionary, for messages
        self.axis_number = axis  #: the device's logical device (``drivers.maps.logical``)
        self.node: Any = canopen.RemoteNode(node_id, od)
        self.node.sdo.RESPONSE_TIMEOUT = self.SDO_TIMEOUT if sdo_timeout is None else sdo_timeout
        self.node.sdo.MAX_RETRIES = self.SDO_RETRIES if sdo_retries is None else sdo_retries
        #: the first axis on its node id holds ``network[node_id]``; another axis of the device joins
        #: the network beside it (canopen's ``add_node`` would take the first one's off)
        self._holds_id = node_id not in network
        if self._holds_id:
            network.add_node(self.node)
        else:
            self.node.associate_network(network)
        self._ON_NODE.setdefault((id(network), node_id), []).append(self)
        self._fault: DeviceFault | None = None
        self.emcy_log: list[str] = []
        self.emcy_texts: dict[int, str] = {}  #: the device's own EMCY texts (its profile's)
        self.node.emcy.add_callback(self._on_emcy)
        self._slots: list[TpdoSlot] = []
        #: heartbeats since the host's last NMT command, and whether one of them was a boot-up
        self._heartbeats = 0
        self._booted = False
        self.node.nmt.add_heartbeat_callback(self._on_heartbeat)
        #: the bus's watch for another master (``drivers.master_watch``), set by the session
        self.master_watch: MasterWatch | None = None
        #: the bus's watch for another producer on the node's TPDOs (``drivers.producer_watch``),
        #: set by the session before ``setup`` (each slot is counted from its making)
        self.producer_watch: ProducerWatch | None = None
        #: an RPDO of another length than its mapping reached the node (its EMCY 0x8210/0x8220)
        self._foreign_rpdo: str | None = None

    def siblings(self) -> list[CanopenAxis]:
        """The other axes alive on this axis's node (the other axes of a drive of several)."""
        return [a for a in self._ON_NODE.get((id(self.network), self.node_id), []) if a is not self]

    @property
    def where(self) -> str:
        """``node 5``, and the axis on a device of several (``node 5 axis 2``)."""
        axes = getattr(self.node.object_dictionary, "axes", 1)
        return f"node {self.node_id}" + (f" axis {self.axis_number}" if axes > 1 else "")

    # --- SDO with the toolkit's errors ---------------------------------------------------
    def _sdo(self, what: str, index: int, subindex: int) -> contextlib.AbstractContextManager[None]:
        """canopen's SDO errors as the toolkit's, naming node and object (``drivers.sdo_errors``)."""
        return sdo_errors(what, index, subindex, node_id=self.node_id, axis=self.axis_number, eds=self.eds)

    def _entry(self, index: int, subindex: int) -> Any:
        """The SDO variable of (index, subindex); no I/O (``hasattr(obj, "raw")`` would read it:
        a write-only object aborts that read)."""
        obj = self.node.sdo[index]
        return obj if isinstance(obj, SdoVariable) else obj[subindex]

    def sdo_read(self, index: int, subindex: int = 0) -> Any:
        """Read an object by SDO (raw bytes if the EDS lacks it); SdoAbort or CommunicationTimeout,
        DictionaryMismatch where the answer's size is not the type's (``drivers.sdo_answer``)."""
        with self._sdo("SDO upload", index, subindex):
            if index not in self.node.object_dictionary:
                return self.node.sdo.upload(axis_object(index, self.axis_number), subindex)
            var = self._entry(index, subindex).od
            with self.node.sdo.open(var.index, subindex, buffering=0) as fp:
                data, indicated = fp.read(), fp.size
            return var.decode_raw(sized(var, data, indicated, node_id=self.node_id, source=self.eds))

    def sdo_upload(self, index: int, subindex: int = 0) -> bytes:
        """An object's raw bytes as the device answers, whatever the EDS names (the device's own
        identity, units and modes: ``drivers.identity.read_standard``); SdoAbort or
        CommunicationTimeout."""
        with self._sdo("SDO upload", index, subindex):
            return bytes(self.node.sdo.upload(axis_object(index, self.axis_number), subindex))

    def check_identity(self, *, give: str) -> Identity:
        """0x1018 read from the device and checked against the EDS in use
        (``drivers.identity.check_identity``; ``give``: how the user gives the device's own), kept
        as ``device_id``."""
        device = read_identity(self.sdo_upload)
        self.device_id = check_identity(
            device,
            self.node.object_dictionary,
            eds=self.eds,
            given=self.eds_given,
            where=f"axis {self.name!r} (node {self.node_id})",
            give=give,
        )
        return self.device_id

    def sdo_write(self, index: int, subindex: int, value: Any) -> None:
        """Write an object by SDO; SdoAbort or CommunicationTimeout on failure."""
        with self._sdo(f"SDO download of {value!r}", index, subindex):
            self._entry(index, subindex).raw = value

    def save_pdos(self, maps: Any, first_index: int) -> None:
        """``maps.save()`` (canopen PdoMaps) with SDO errors translated."""
        with self._sdo("PDO mapping", first_index, 0):
            maps.save()

    # --- NMT, EMCY, heartbeat ----------------------------------------------------------------
    def nmt(self, state: str) -> None:
        """Command the node's NMT state (``OPERATIONAL``, ``PRE-OPERATIONAL``, ``STOPPED``)."""
        self._heartbeats, self._booted = 0, False
        self.node.nmt.state = state

    def _on_heartbeat(self, state: int) -> None:
        """canopen's heartbeat callback (receive thread), before it updates the state."""
        self._heartbeats += 1
        if state == cia.BOOT_UP:
            self._booted = True

    @property
    def nmt_state(self) -> str:
        """The node's NMT state as last commanded or reported (heartbeat, boot-up)."""
        return str(self.node.nmt.state)

    @property
    def last_heartbeat(self) -> float | None:
        """Timestamp [s] of the last heartbeat received, or None."""
        ts = self.node.nmt.timestamp
        return float(ts) if ts is not None else None

    def _on_emcy(self, err: EmcyError) -> None:
        words = emcy_text(err.code, self.emcy_texts)
        text = f"EMCY 0x{err.code:04X} ({words}), error register 0x{err.register:02X}"
        self.emcy_log.append(text)
        if err.code in _PDO_LENGTH and self._foreign_rpdo is None:
            # CiA 301: the node did not process a PDO whose length is not its mapping's; it tells,
            # and goes on (no state change: a drive's "info" reaction). The host's RPDOs have their
            # mapping's length: another producer sent on the node's RPDO COB-ID. A stop, named so;
            # not a fault of the drive (a stop it comes in stays confirmable by state and rest)
            self._foreign_rpdo = (
                f"node {self.node_id}: another producer on an RPDO COB-ID of node {self.node_id}: the node "
                f"refused a PDO of another length than its mapping ({text}), which this host did not send"
            )
            log.warning("%s", self._foreign_rpdo)
            return
        if err.code and err.code not in _PDO_LENGTH:
            log.warning("node %d: %s", self.node_id, text)
            self._fault = DeviceFault(text, device=f"node {self.node_id}", code=err.code)

    @property
    def fault(self) -> DeviceFault | None:
        return self._fault

    def clear_fault(self) -> None:
        self._fault = None

    def supervise(self, now: float) -> None:
        """EMCY fault, another master's RPDO or NMT command to the node, NMT state (must be
        OPERATIONAL) and heartbeat age (``heartbeat_timeout``).

        A heartbeat the node sent before it processed the host's NMT command can arrive after
        the command: the first heartbeat after a command is not taken as the node's state
        unless it is a boot-up; the next one is (one heartbeat period later).
        """
        if self._fault is not None:
            raise self._fault
        watch = self.master_watch
        if watch is not None and watch.alarm:
            said = watch.intruder(self.node_id)
            if said is not None:
                raise OtherMaster(said)
        producers = self.producer_watch
        if producers is not None and producers.alarm:
            said = producers.intruder(self.node_id)
            if said is not None:
                raise OtherProducer(said)
        if self._foreign_rpdo is not None:
            raise OtherProducer(self._foreign_rpdo)
        lost = getattr(self.network.notifier, "exception", None)  # python-can's receive thread
        if lost is not None:
            raise CommunicationError(f"node {self.node_id}: the bus is lost: {brief(lost)}")
        state = self.node.nmt.state
        if state != "OPERATIONAL" and (self._booted or self._heartbeats > 1):
            raise SafetyStop(f"node {self.node_id}: NMT state {state} (the node reset or was stopped)")
        timeout = self.heartbeat_timeout
        if timeout > 0.0:
            last = self.node.nmt.timestamp
            if last is not None and now - last > timeout:
                age = now - last
                raise SafetyStop(
                    f"node {self.node_id}: heartbeat lost: none for {age:.3g} s (timeout {timeout:g} s)"
                )

    # --- process data ---------------------------------------------------------------------------
    def receive(self, pdo: Any) -> TpdoSlot:
        """Receive TPDO ``pdo`` (a saved canopen PdoMap) into a slot, instead of canopen's handler."""
        slot = self._new_slot(pdo.cob_id, pdo_codec(pdo))
        if pdo.trans_type is not None:
            slot.ttype = int(pdo.trans_type)
        if pdo.on_message in self.network.subscribers.get(pdo.cob_id, ()):
            self.network.unsubscribe(pdo.cob_id, pdo.on_message)
        self.network.subscribe(pdo.cob_id, slot.on_frame)
        self._slots.append(slot)
        return slot

    def receive_cob(self, cob_id: int, codec: struct.Struct) -> TpdoSlot:
        """Receive the TPDO on ``cob_id`` into a slot decoded by ``codec`` (its mapping in force)."""
        slot = self._new_slot(cob_id, codec)
        self.network.subscribe(cob_id, slot.on_frame)
        self._slots.append(slot)
        return slot

    def _new_slot(self, cob_id: int, codec: struct.Struct) -> TpdoSlot:
        """A slot for the TPDO on ``cob_id``, counted by the producer watch from now on."""
        slot = TpdoSlot(self.node_id, cob_id, codec)
        if self.producer_watch is not None:
            self.producer_watch.watch(slot)
        return slot

    def has_sample(self) -> bool:
        """Every TPDO the axis receives has arrived at least once."""
        return all(slot.timestamp is not None for slot in self._slots)

    def cycle_frames(self) -> list[tuple[str, int]]:
        """The axis's frames of each cycle on the bus, as (what it is, its data bytes): the TPDOs
        it receives (a drive adds its RPDO)."""
        return [(f"TPDO 0x{s.cob_id:03X}", s.codec.size) for s in self._slots]

    def tpdo_cob_ids(self) -> Sequence[int]:
        """The COB-IDs of the TPDOs the axis receives that answer every SYNC (transmission type 1):
        a pacing waits for them after each SYNC (``tpdos_not_awaited``: the others)."""
        return [s.cob_id for s in self._slots if s.ttype == 1]

    def tpdos_not_awaited(self) -> list[tuple[int, int]]:
        """(COB-ID, transmission type) of the TPDOs the axis receives that do not answer every
        SYNC (CiA 301: 2-240 every n-th, counted from a start the host does not know; 0, 254, 255
        only on an event): a pacing cannot wait for them without counting as owed an answer the
        node will not send."""
        return [(s.cob_id, s.ttype) for s in self._slots if s.ttype != 1]

    def _release(self) -> None:
        for slot in self._slots:
            self.network.unsubscribe(slot.cob_id, slot.on_frame)
        self._slots.clear()
        on_node = self._ON_NODE.get((id(self.network), self.node_id), [])
        if self in on_node:
            on_node.remove(self)
            if not on_node:
                del self._ON_NODE[(id(self.network), self.node_id)]
        if self._holds_id and self.node_id in self.network and self.network[self.node_id] is self.node:
            del self.network[self.node_id]
        else:
            self.node.remove_network()
