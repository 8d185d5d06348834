"""The host's watch of one CANopen node, a part of ``drivers.canopen_axis.CanopenAxis``.

``NodeWatch`` listens to the node's EMCY (one with a non-zero code becomes the axis's fault) and
heartbeat (a boot-up, and how many came since the host's last NMT command), and checks once a
cycle (``check``): the fault; another master's RPDO or NMT command to the node
(``drivers.master_watch``); another producer on its TPDOs (``drivers.producer_watch``) or on its
RPDOs (the node's EMCY saying it refused a PDO of another length than its mapping); the bus's
receive thread; the NMT state (OPERATIONAL); the heartbeat's age. The part owns its state; what it
needs of its axis is ``WatchedAxis``.
"""

from __future__ import annotations

import logging
from typing import Any, Protocol

import canopen
from canopen.emcy import EmcyError

from drivers.errors import CommunicationError, DeviceFault, SafetyStop, brief
from drivers.maps import cia
from drivers.maps.emcy import emcy_text
from drivers.master_watch import MasterWatch, OtherMaster
from drivers.producer_watch import OtherProducer, ProducerWatch

__all__ = ["NodeWatch"]

log = logging.getLogger(__name__)

#: EMCY codes of a PDO not processed for its length (CiA 301: too short, too long)
_PDO_LENGTH = frozenset({cia.EmcyCode.PDO_TOO_SHORT, cia.EmcyCode.PDO_TOO_LONG})


class WatchedAxis(Protocol):
    """What the watch needs of its axis (``drivers.canopen_axis.CanopenAxis``)."""

    node: Any  #: its canopen ``RemoteNode``
    node_id: int
    network: canopen.Network
    heartbeat_timeout: float  #: [s]; 0: not supervised
    emcy_texts: dict[int, str]  #: the device's own EMCY texts
    master_watch: MasterWatch | None  #: the bus's watch for another master
    producer_watch: ProducerWatch | None  #: the bus's watch for another producer


class NodeWatch:
    """EMCY, heartbeat and NMT state of one node, checked once a cycle (see the module docstring).

    Parameters
    ----------
    axis : WatchedAxis
        The axis on the node; the watch subscribes to the node's EMCY and heartbeat.
    """

    def __init__(self, axis: WatchedAxis) -> None:
        self.axis = axis
        self.fault: DeviceFault | None = None  #: the last EMCY with a non-zero code, as a fault
        self.emcy_log: list[str] = []  #: every EMCY received, in words
        #: heartbeats since the host's last NMT command, and whether one of them was a boot-up
        self.heartbeats = 0
        self.booted = False
        #: an RPDO of another length than its mapping reached the node (its EMCY 0x8210/0x8220)
        self.foreign_rpdo: str | None = None
        axis.node.emcy.add_callback(self.on_emcy)
        axis.node.nmt.add_heartbeat_callback(self.on_heartbeat)

    def commanded(self) -> None:
        """The host commands the node's NMT state now: heartbeats are counted afresh."""
        self.heartbeats, self.booted = 0, False

    def on_heartbeat(self, state: int) -> None:
        """canopen's heartbeat callback (receive thread), before it updates the state.

        Parameters
        ----------
        state : int
            The NMT state the heartbeat reports (0: a boot-up).
        """
        self.heartbeats += 1
        if state == cia.BOOT_UP:
            self.booted = True

    def on_emcy(self, err: EmcyError) -> None:
        """canopen's EMCY callback: logged; a non-zero code is the axis's fault, a PDO's length
        refused names another producer on the node's RPDO COB-ID.

        Parameters
        ----------
        err : canopen.emcy.EmcyError
            The EMCY received.
        """
        node_id = self.axis.node_id
        words = emcy_text(err.code, self.axis.emcy_texts)
        text = f"EMCY 0x{err.code:04X} ({words}), error register 0x{err.register:02X}"
        self.emcy_log.append(text)
        if err.code in _PDO_LENGTH and self.foreign_rpdo is None:
            # CiA 301: the node did not process a PDO whose length is not its mapping's; it tells,
            # and goes on (no state change: a drive's "info" reaction). The host's RPDOs have their
            # mapping's length: another producer sent on the node's RPDO COB-ID. A stop, named so;
            # not a fault of the drive (a stop it comes in stays confirmable by state and rest)
            self.foreign_rpdo = (
                f"node {node_id}: another producer on an RPDO COB-ID of node {node_id}: the node "
                f"refused a PDO of another length than its mapping ({text}), which this host did not send"
            )
            log.warning("%s", self.foreign_rpdo)
            return
        if err.code and err.code not in _PDO_LENGTH:
            log.warning("node %d: %s", node_id, text)
            self.fault = DeviceFault(text, device=f"node {node_id}", code=err.code)

    def check(self, now: float) -> None:
        """EMCY fault, another master's RPDO or NMT command to the node, another producer, the
        bus's receive thread, NMT state (must be OPERATIONAL) and heartbeat age
        (``heartbeat_timeout``).

        A heartbeat the node sent before it processed the host's NMT command can arrive after
        the command: the first heartbeat after a command is not taken as the node's state
        unless it is a boot-up; the next one is (one heartbeat period later).

        Parameters
        ----------
        now : float
            [s] the bus clock (the heartbeat's age is measured to it).

        Raises
        ------
        DeviceFault
            The node sent an EMCY with a non-zero code.
        OtherMaster, OtherProducer
            Another master or producer sent on the node's COB-IDs.
        CommunicationError
            The bus's receive thread died.
        SafetyStop
            The node left OPERATIONAL, or its heartbeat is older than ``heartbeat_timeout``.
        """
        if self.fault is not None:
            raise self.fault
        axis = self.axis
        node_id = axis.node_id
        watch = axis.master_watch
        if watch is not None and watch.alarm:
            said = watch.intruder(node_id)
            if said is not None:
                raise OtherMaster(said)
        producers = axis.producer_watch
        if producers is not None and producers.alarm:
            said = producers.intruder(node_id)
            if said is not None:
                raise OtherProducer(said)
        if self.foreign_rpdo is not None:
            raise OtherProducer(self.foreign_rpdo)
        lost = getattr(axis.network.notifier, "exception", None)  # python-can's receive thread
        if lost is not None:
            raise CommunicationError(f"node {node_id}: the bus is lost: {brief(lost)}")
        nmt = axis.node.nmt
        state = nmt.state
        if state != "OPERATIONAL" and (self.booted or self.heartbeats > 1):
            raise SafetyStop(f"node {node_id}: NMT state {state} (the node reset or was stopped)")
        timeout = axis.heartbeat_timeout
        if timeout > 0.0:
            last = nmt.timestamp
            if last is not None and now - last > timeout:
                age = now - last
                raise SafetyStop(
                    f"node {node_id}: heartbeat lost: none for {age:.3g} s (timeout {timeout:g} s)"
                )
