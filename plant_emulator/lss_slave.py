"""The emulated nodes' LSS slave (CiA 305): how a fresh drive gets its node-ID and bit rate over
the bus, and how a configured one changes them.

A node whose EDS says ``LSS_Supported=1``, or that starts with node-ID 255 (unconfigured: it
answers LSS and nothing else, sends no boot-up and no heartbeat), has an ``LssSlave`` on
COB-ID 0x7E5, answering on 0x7E4 (``drivers.maps.lss``). As CiA 305 has it:

- switch state global (configuration or waiting) in either state; switch state selective by the
  four entries of 0x1018 (vendor, product, revision, serial) in the waiting state, answered 0x44;
- in the configuration state: configure node-ID (1..127, or 255; another is error 1), configure
  bit timing (table 0, a rate the EDS's ``BaudRate_*`` lists; another is error 1), activate bit
  timing, store configuration (always supported: error 0), inquire identity (0x1018 sub 1-4) and
  node-ID (the active one: 255 while unconfigured);
- identify remote slave (a vendor, a product and ranges of revision and serial) and identify
  non-configured remote slave (answered by a node with node-ID 255) in either state;
- fastscan (CiA 305 v2.2: bit 0x80 starts it, then each bit of the four entries, most significant
  first; a full match puts the slave in the configuration state), by unconfigured slaves in the
  waiting state only.

A node-ID configured is pending: it is the node's at its next NMT reset communication, or, for a
node that was unconfigured, when it is switched back to the waiting state (it then boots with its
new node-ID). An NMT reset node (the application's reset, as at power-on) takes the node-ID and
bit rate stored by store configuration, so one configured and not stored is lost to it; the store
lasts as long as the emulator's process. The emulated bus carries any bit rate: a bit rate
activated is the node's (``bitrate``), and the node goes on answering, where on a real bus the
master and every other node would switch with it after the switch delay.
"""

from __future__ import annotations

import struct
from typing import Any

from drivers.maps import cia
from drivers.maps.eds_values import parse_value, variables
from drivers.maps.lss import BIT_TIMINGS, COB_MASTER, COB_SLAVE, FASTSCAN_CONFIRM, UNCONFIGURED, Cs, LssState

__all__ = ["UNCONFIGURED", "LssSlave", "check_node_id", "lss_slave", "renumber", "speaks_lss"]

_U32 = struct.Struct("<I")
_MASK = 0xFFFFFFFF


def speaks_lss(od: Any, node_id: int) -> bool:
    """Whether a node answers LSS: its EDS says so, or it has no node-ID yet.

    Parameters
    ----------
    od : Any
        The node's object dictionary.
    node_id : int
        Its node-ID (255: none yet).

    Returns
    -------
    bool
        Whether it answers LSS.
    """
    info = getattr(od, "device_information", None)
    return bool(getattr(info, "LSS_supported", False)) or node_id == UNCONFIGURED


def check_node_id(node_id: int) -> int:
    """``node_id`` where an emulated node may have it: 1..127, or 255 (none yet: LSS only).

    Parameters
    ----------
    node_id : int
        The node-ID.

    Returns
    -------
    int
        ``node_id``.

    Raises
    ------
    ValueError
        If it is not 1..127 or 255.
    """
    if node_id not in cia.NODE_IDS and node_id != UNCONFIGURED:
        raise ValueError(f"node id must be 1..127 (or 255: none yet, LSS only), got {node_id!r}")
    return node_id


def lss_slave(node: Any) -> LssSlave | None:
    """The LSS slave of ``node`` (an ``EmulatedNode``), where it speaks LSS (``speaks_lss``).

    Parameters
    ----------
    node : Any
        An ``EmulatedNode``.

    Returns
    -------
    LssSlave | None
        Its LSS slave; None where it does not speak LSS.
    """
    return LssSlave(node) if speaks_lss(node.node.object_dictionary, node.node_id) else None


class LssSlave:
    """The LSS slave of an emulated node (``plant_emulator.canopen_node.EmulatedNode``).

    Parameters
    ----------
    node : Any
        An ``EmulatedNode``.
    """

    def __init__(self, node: Any) -> None:
        self.node = node
        self.state = LssState.WAITING
        self.pending = self.stored = node.node_id  #: node-ID pending and stored
        rates = node.node.object_dictionary.device_information.allowed_baudrates
        self.rates = frozenset(rates) or frozenset(BIT_TIMINGS.values())  #: [bit/s] the device takes
        self.bitrate = max(self.rates)  #: [bit/s] the node's bit rate now
        self.stored_bitrate = self.bitrate
        self.pending_bitrate: int | None = None
        self._selected: dict[int, int] = {}  #: switch state selective's entries so far
        self._identify: dict[int, int] = {}  #: identify remote slave's entries so far
        self._fastscan = 0  #: the entry (0-3) of 0x1018 the fastscan checks next
        node.network.subscribe(COB_MASTER, self.on_frame)

    def address(self) -> tuple[int, int, int, int]:
        """The LSS address: 0x1018 sub 1-4.

        Returns
        -------
        tuple[int, int, int, int]
            (vendor, product, revision, serial).
        """
        read = self.node.read
        return tuple(int(read(cia.IDENTITY, sub)) for sub in (1, 2, 3, 4))  # type: ignore[return-value]

    def _answer(self, cs: int, data: bytes = b"") -> None:
        self.node._send(COB_SLAVE, bytes([cs, *data]).ljust(8, b"\0"))

    def on_frame(self, can_id: int, data: bytes, timestamp: float) -> None:
        """An LSS master request (COB-ID 0x7E5): answered as CiA 305 says.

        Parameters
        ----------
        can_id : int
            The frame's identifier.
        data : bytes
            Its 8 bytes (others ignored).
        timestamp : float
            [s] when it came.
        """
        if len(data) != 8:
            return
        cs, value = data[0], _U32.unpack_from(data, 1)[0]
        if cs == Cs.SWITCH_GLOBAL:
            self._switch(data[1])
        elif Cs.IDENTIFY_VENDOR <= cs <= Cs.IDENTIFY_SERIAL_HIGH:
            self._identify_remote(cs - Cs.IDENTIFY_VENDOR, value)
        elif cs == Cs.IDENTIFY_NON_CONFIGURED:
            if self.node.node_id == UNCONFIGURED:
                self._answer(Cs.NON_CONFIGURED_SLAVE)
        elif self.state == LssState.WAITING:
            if Cs.SELECT_VENDOR <= cs <= Cs.SELECT_SERIAL:
                self._select(cs - Cs.SELECT_VENDOR, value)
            elif cs == Cs.FASTSCAN:
                self._fastscan_step(value, *data[5:8])
        else:
            self._configure(cs, data)

    def _switch(self, mode: int) -> None:
        if mode == LssState.CONFIGURATION:
            self.state = LssState.CONFIGURATION
        elif mode == LssState.WAITING:
            was = self.state
            self.state, self._selected = LssState.WAITING, {}
            if was == LssState.CONFIGURATION and self.node.node_id == UNCONFIGURED != self.pending:
                self.node.reset(comm_only=True)  # it had none: it starts with its new node-ID

    def _select(self, entry: int, value: int) -> None:
        self._selected[entry] = value
        if entry == 3:
            named = tuple(self._selected.get(i) for i in range(4))
            self._selected = {}
            if named == self.address():
                self.state = LssState.CONFIGURATION
                self._answer(Cs.SELECTED)

    def _identify_remote(self, entry: int, value: int) -> None:
        self._identify[entry] = value
        if entry == 5:
            got, self._identify = self._identify, {}
            if len(got) != 6:
                return
            vendor, product, revision, serial = self.address()
            if (
                (vendor, product) == (got[0], got[1])
                and got[2] <= revision <= got[3]
                and got[4] <= serial <= got[5]
            ):
                self._answer(Cs.IDENTIFY_SLAVE)

    def _fastscan_step(self, value: int, bit: int, sub: int, next_sub: int) -> None:
        if self.node.node_id != UNCONFIGURED or self.pending != UNCONFIGURED:
            return  # only slaves without a node-ID take part
        if bit == FASTSCAN_CONFIRM:
            self._fastscan = 0
            self._answer(Cs.IDENTIFY_SLAVE)
            return
        if bit > 31 or sub > 3 or next_sub > 3 or sub != self._fastscan:
            return
        mask = (_MASK << bit) & _MASK
        if self.address()[sub] & mask != value & mask:
            return
        self._fastscan = next_sub
        if bit == 0 and next_sub < sub:
            self.state = LssState.CONFIGURATION  # the whole address matched
        self._answer(Cs.IDENTIFY_SLAVE)

    def _configure(self, cs: int, data: bytes) -> None:
        """A service of the configuration state."""
        if cs == Cs.CONFIGURE_NODE_ID:
            ok = data[1] in cia.NODE_IDS or data[1] == UNCONFIGURED
            if ok:
                self.pending = data[1]
            self._answer(cs, bytes([0 if ok else 1]))
        elif cs == Cs.CONFIGURE_BIT_TIMING:
            rate = BIT_TIMINGS.get(data[2]) if data[1] == 0 else None
            ok = rate in self.rates
            if ok:
                self.pending_bitrate = rate
            self._answer(cs, bytes([0 if ok else 1]))
        elif cs == Cs.ACTIVATE_BIT_TIMING:
            if self.pending_bitrate is not None:
                self.bitrate = self.pending_bitrate
        elif cs == Cs.STORE_CONFIGURATION:
            self.stored = self.pending
            self.stored_bitrate = self.pending_bitrate or self.bitrate
            self._answer(cs, b"\0")
        elif Cs.INQUIRE_VENDOR <= cs <= Cs.INQUIRE_SERIAL:
            self._answer(cs, _U32.pack(self.address()[cs - Cs.INQUIRE_VENDOR]))
        elif cs == Cs.INQUIRE_NODE_ID:
            self._answer(cs, bytes([self.node.node_id]))

    def on_reset(self, *, application: bool) -> None:
        """An NMT reset (``application``: reset node, which takes the stored configuration) or
        reset communication: back to waiting, and the pending node-ID becomes the node's.

        Parameters
        ----------
        application : bool
            Reset node (else reset communication).
        """
        if application:
            self.pending, self.bitrate, self.pending_bitrate = self.stored, self.stored_bitrate, None
        self.state, self._selected, self._identify, self._fastscan = LssState.WAITING, {}, {}, 0
        if self.pending != self.node.node_id:
            renumber(self.node, self.pending)


def renumber(node: Any, new: int) -> None:
    """``node`` (an ``EmulatedNode``) takes node-ID ``new``: its SDO, EMCY and NMT identifiers, and
    the defaults CiA 306 writes relative to the node-ID (``$NODEID+0x180``...). An entry of the
    reset image (or of the stored parameters' defaults) that held the old node-ID's default goes,
    so the new default is in force after the reset that follows.

    Parameters
    ----------
    node : Any
        An ``EmulatedNode``.
    new : int
        Its new node-ID, 1..127.
    """
    old, local, net = node.node_id, node.node, node.network
    od = local.object_dictionary
    net.unsubscribe(local.sdo.rx_cobid, node._on_sdo)
    local.sdo.rx_cobid, local.sdo.tx_cobid = cia.COB_SDO_RX + new, cia.COB_SDO_TX + new
    net.subscribe(local.sdo.rx_cobid, node._on_sdo)
    local.emcy.cob_id = cia.COB_EMCY + new
    local.id = local.nmt.id = new
    net.nodes.pop(old, None)
    net.nodes[new] = local
    node.node_id = new
    images = [i for i in (node._power_on, node.params.factory) if i is not None]
    for var in variables(od):
        for raw, attr in (("default_raw", "default"), ("value_raw", "value")):
            text = getattr(var, raw, None)
            if not text or "$NODEID" not in text.upper():
                continue
            was = var.encode_raw(getattr(var, attr))
            setattr(var, attr, parse_value(text, var.data_type, new))
            for image in images:
                if image.get(var.index, {}).get(var.subindex) == was:
                    del image[var.index][var.subindex]
    node.od.clear()
