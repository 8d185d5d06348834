"""What every CANopen axis shares: one node on a canopen ``RemoteNode``, with the toolkit's errors.

``CanopenAxis`` gives its subclasses (the CiA 402 drive, the CiA 406 encoder) SDO access that
raises ``SdoAbort``/``CommunicationTimeout`` naming the node and object, and NMT commands; it
composes two parts that own their state: the node's watch (``drivers.node_watch.NodeWatch``: the
EMCY consumer, an EMCY with a non-zero code becoming the axis's ``fault``, and the per-cycle
supervision of NMT state, heartbeat and other masters or producers) and the TPDOs it receives
(``drivers.tpdo_receiver.TpdoReceiver``, into ``drivers.tpdo_slot.TpdoSlot``, re-exported here with
``pdo_codec`` and ``sample_interval``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from typing import Any, ClassVar

import canopen
from canopen.sdo.base import SdoVariable

from drivers.base import AxisDriver
from drivers.errors import DeviceFault
from drivers.identity import Identity, check_identity, read_identity
from drivers.maps.logical import axis_dictionary, axis_object
from drivers.maps.od import load_od
from drivers.master_watch import MasterWatch
from drivers.node_watch import NodeWatch
from drivers.producer_watch import ProducerWatch
from drivers.sdo_answer import sized
from drivers.sdo_errors import sdo_errors
from drivers.tpdo_receiver import TpdoReceiver
from drivers.tpdo_slot import TpdoSlot, pdo_codec, sample_interval

__all__ = ["CanopenAxis", "TpdoSlot", "pdo_codec", "sample_interval"]


class CanopenAxis(AxisDriver):
    """An axis on a CANopen node. Axes of one node (the logical devices of a drive of several)
    share the node's communication objects; each has its own canopen ``RemoteNode`` on the
    network (the first on its node id holds ``network[node_id]``).

    Parameters
    ----------
    name : str
        The axis's name, in messages.
    mode : str or None
        One of ``drivers.base.AXIS_MODES`` (None: an axis that takes no commands).
    network : canopen.Network
        The network of its node.
    node_id : int
        Its node id (1-127).
    eds : str
        The EDS/DCF that describes the device.
    eds_given : bool
        ``eds`` is the device's own, given by the user; else the toolkit's, used as a generic
        dictionary of the profile's standard objects.
    heartbeat_timeout : float
        [s] the host's watch of the node's heartbeat (0: none).
    sdo_timeout, sdo_retries : float or None, int or None
        Of every SDO transfer (None: ``SDO_TIMEOUT``, ``SDO_RETRIES``).
    axis : int
        Which of the device's logical devices (``drivers.maps.logical``: its objects 0x800
        (axis - 1) above axis 1's, which are the indices this class and its subclasses name).

    Raises
    ------
    ValueError
        ``node_id`` is not 1-127.
    """

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
        self.emcy_texts: dict[int, str] = {}  #: the device's own EMCY texts (its profile's)
        #: the bus's watch for another master (``drivers.master_watch``), set by the session
        self.master_watch: MasterWatch | None = None
        #: the bus's watch for another producer on the node's TPDOs (``drivers.producer_watch``),
        #: set by the session before ``setup`` (each slot is counted from its making)
        self.producer_watch: ProducerWatch | None = None
        self.watch = NodeWatch(self)  #: the node's EMCY, heartbeat and NMT state (its part)
        self.tpdos = TpdoReceiver(self)  #: the TPDOs it receives (its part)

    def siblings(self) -> list[CanopenAxis]:
        """The other axes alive on this axis's node (the other axes of a drive of several).

        Returns
        -------
        list of CanopenAxis
            Each other axis on the node, not yet closed.
        """
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
        """Read an object by SDO, decoded by the EDS's type (``drivers.sdo_answer``: an answer of
        another size than the type's is a DictionaryMismatch); raw bytes where the EDS lacks it.

        Parameters
        ----------
        index, subindex : int
            The object (axis 1's index: ``drivers.maps.logical``).

        Returns
        -------
        Any
            Its value.
        """
        with self._sdo("SDO upload", index, subindex):
            if index not in self.node.object_dictionary:
                return self.node.sdo.upload(axis_object(index, self.axis_number), subindex)
            var = self._entry(index, subindex).od
            with self.node.sdo.open(var.index, subindex, buffering=0) as fp:
                data, indicated = fp.read(), fp.size
            return var.decode_raw(sized(var, data, indicated, node_id=self.node_id, source=self.eds))

    def sdo_upload(self, index: int, subindex: int = 0) -> bytes:
        """An object's raw bytes as the device answers, whatever the EDS names (the device's own
        identity, units and modes: ``drivers.identity.read_standard``).

        Parameters
        ----------
        index, subindex : int
            The object (axis 1's index).

        Returns
        -------
        bytes
            The answer.
        """
        with self._sdo("SDO upload", index, subindex):
            return bytes(self.node.sdo.upload(axis_object(index, self.axis_number), subindex))

    def check_identity(self, *, give: str) -> Identity:
        """0x1018 read from the device, checked against the EDS in use and kept as ``device_id``
        (``drivers.identity.check_identity``).

        Parameters
        ----------
        give : str
            How the user gives the device's own EDS, for the message.

        Returns
        -------
        drivers.identity.Identity
            The device's 0x1018.
        """
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
        """Write an object by SDO, encoded by the EDS's type.

        Parameters
        ----------
        index, subindex : int
            The object (axis 1's index).
        value : Any
            What to write.
        """
        with self._sdo(f"SDO download of {value!r}", index, subindex):
            self._entry(index, subindex).raw = value

    def save_pdos(self, maps: Any, first_index: int) -> None:
        """``maps.save()`` with the SDO errors translated.

        Parameters
        ----------
        maps : canopen.pdo.PdoBase
            The node's RPDOs or TPDOs.
        first_index : int
            Their first communication parameter (0x1400, 0x1800), for messages.
        """
        with self._sdo("PDO mapping", first_index, 0):
            maps.save()

    # --- NMT, EMCY, heartbeat: the node's watch (``drivers.node_watch``) ----------------------
    def nmt(self, state: str) -> None:
        """Command the node's NMT state.

        Parameters
        ----------
        state : str
            ``OPERATIONAL``, ``PRE-OPERATIONAL`` or ``STOPPED``.
        """
        self.watch.commanded()
        self.node.nmt.state = state

    @property
    def nmt_state(self) -> str:
        """The node's NMT state as last commanded or reported (heartbeat, boot-up)."""
        return str(self.node.nmt.state)

    @property
    def last_heartbeat(self) -> float | None:
        """Timestamp [s] of the last heartbeat received, or None."""
        ts = self.node.nmt.timestamp
        return float(ts) if ts is not None else None

    @property
    def fault(self) -> DeviceFault | None:
        """The last EMCY with a non-zero code, as a fault (``NodeWatch``), or None."""
        return self.watch.fault

    def clear_fault(self) -> None:
        """Forget the last EMCY fault (before an enable or a fault reset)."""
        self.watch.fault = None

    def supervise(self, now: float) -> None:
        """The node's watch, once a cycle (``drivers.node_watch.NodeWatch.check``).

        Parameters
        ----------
        now : float
            [s] the bus clock (the heartbeat's age is measured to it).
        """
        self.watch.check(now)

    # --- process data: the TPDOs it receives (``drivers.tpdo_receiver``) ----------------------
    def has_sample(self) -> bool:
        return self.tpdos.has_sample()

    def cycle_frames(self) -> list[tuple[str, int]]:
        """The axis's frames of each cycle on the bus: the TPDOs it receives (a drive adds its RPDO).

        Returns
        -------
        list of (str, int)
            (what the frame is, its data bytes) for each.
        """
        return self.tpdos.frames()

    def tpdo_cob_ids(self) -> Sequence[int]:
        """The COB-IDs of the TPDOs the axis receives that answer every SYNC (transmission type 1).

        Returns
        -------
        Sequence of int
            What a pacing waits for after each SYNC (``tpdos_not_awaited``: the others).
        """
        return self.tpdos.cob_ids()

    def tpdos_not_awaited(self) -> list[tuple[int, int]]:
        """(COB-ID, transmission type) of the TPDOs the axis receives that do not answer every SYNC.

        Returns
        -------
        list of (int, int)
            What a pacing cannot wait for (``TpdoReceiver.not_awaited``).
        """
        return self.tpdos.not_awaited()

    def _release(self) -> None:
        self.tpdos.release()
        on_node = self._ON_NODE.get((id(self.network), self.node_id), [])
        if self in on_node:
            on_node.remove(self)
            if not on_node:
                del self._ON_NODE[(id(self.network), self.node_id)]
        if self._holds_id and self.node_id in self.network and self.network[self.node_id] is self.node:
            del self.network[self.node_id]
        else:
            self.node.remove_network()
