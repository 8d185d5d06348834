"""Another master on the bus: the frames only a master sends, heard from someone else.

A CANopen bus has one master driving a node: the one that sends its NMT commands (CiA 301 7.2.8),
its RPDOs (7.2.2) and, unless a device produces it, the SYNC (7.2.5). ``MasterWatch`` subscribes,
on the host's canopen ``Network``, to the NMT COB-ID (0x000), the SYNC (0x080), and the RPDO
COB-IDs of the host's nodes (0x200/0x300/0x400/0x500 + node, and any other the set-up maps).
python-can delivers no frame a bus sent to its own receive path on SocketCAN, socketcand and the
virtual bus, so there every frame heard was sent by another node. Some adapters give the host its
own frames back all the same (a candleLight's gs_usb firmware echoes every frame it sends, ICS
neoVI does by default, python-can's udp_multicast loops them back): the watch keeps the frames the
host sends on these COB-IDs (it wraps the network's ``send_message``) and learns whether the bus
echoes from the host's own SDO requests (0x600 + node), which it also listens to; on a bus that
echoes, a frame equal to one the host sent and not yet heard back is its echo, not another master.
Frames the host sends through another socket (the kernel's broadcast manager's SYNC) are sent only
once the run is under way, after ``check``.

- ``check(window)``: before anything is enabled: wait until ``window`` [s] have passed since the
  watch began (at the bus's opening) and raise ``OtherMaster`` naming what was heard (COB-ID and
  rate) and ``[bus] sync = "external"`` as the way to share a SYNC producer.
- ``watch_sync()``: once the run's pacing is the host's own SYNC, sent through the network (so
  never heard back but as an adapter's echo): a SYNC heard from then on is a second producer's,
  which paces every node of the bus (CiA 301 7.2.5: one SYNC producer per network).
- ``intruder(node_id)``: while running: an RPDO to that node, an NMT command to it, or (after
  ``watch_sync``) a SYNC, that the host did not send, in words (None: none); the axis's
  supervision makes it a safe stop.
"""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

from drivers.errors import SafetyStop
from drivers.maps import cia

__all__ = ["MasterWatch", "OtherMaster"]

#: frames kept per watched COB-ID until heard back (a bus that echoes gives them back within ms)
_KEPT = 64

_NMT_WORDS = {
    cia.NmtCommand.START: "start",
    cia.NmtCommand.STOP: "stop",
    cia.NmtCommand.PRE_OPERATIONAL: "enter pre-operational",
    cia.NmtCommand.RESET_NODE: "reset node",
    cia.NmtCommand.RESET_COMMUNICATION: "reset communication",
}


class OtherMaster(SafetyStop):
    """Another master was heard on the bus (before the start: a refusal; while running: a stop)."""


class MasterWatch:
    """See the module docstring; ``sync``: the host produces SYNC (a SYNC heard is another's).

    Parameters
    ----------
    network : Any
        The host's canopen ``Network``.
    node_ids : Iterable[int]
        The host's nodes.
    sync : bool, optional
        The host produces SYNC (a SYNC heard is another's).
    clock : Callable[[], float], optional
        [s] the time source (``time.monotonic``).
    """

    def __init__(
        self,
        network: Any,
        node_ids: Iterable[int],
        *,
        sync: bool = True,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.network = network
        self.nodes = frozenset(node_ids)
        self.sync = sync
        self._clock = clock
        self.began = clock()
        self._lock = threading.Lock()
        #: COB-ID -> (frames heard, first and last timestamp [s], last data)
        self.heard: dict[int, list[Any]] = {}
        self._rpdo_node: dict[int, int] = {}
        self._cobs: list[int] = []
        #: an RPDO or an NMT command to the host's nodes (or a SYNC, after ``watch_sync``) was heard
        #: (the per-cycle test is this flag)
        self.alarm = False
        self.sync_watched = False  #: the run's SYNC is the host's: another one is a second producer
        #: the bus gives the host its own frames back (learned from its SDO requests' echoes)
        self.echoes = False
        self.echoes_seen = 0  #: the host's own frames heard back and set aside
        #: COB-ID -> the data of the frames the host sent on it, not yet heard back (oldest first)
        self._sent: dict[int, collections.deque[bytes]] = {}
        self._sdo_requests = frozenset(cia.COB_SDO_RX + node for node in self.nodes)
        self._send = network.send_message
        network.send_message = self._sending
        self._listen(cia.COB_NMT)
        if sync:
            self._listen(cia.COB_SYNC)
        for node in sorted(self.nodes):
            self._listen(cia.COB_SDO_RX + node)
            for base in cia.COB_RPDO:
                self.add_rpdo(base + node, node)

    def _sending(self, can_id: int, data: bytes, remote: bool = False) -> None:
        """The network's ``send_message``, keeping what is sent on a watched COB-ID (its echo)."""
        if can_id in self._sent:
            self._sent[can_id].append(bytes(data))
        self._send(can_id, data, remote)

    def _echo(self, can_id: int, data: bytes) -> bool:
        """``data`` on ``can_id`` is a frame the host sent and had not yet heard back."""
        sent = self._sent.get(can_id)
        if not sent or data not in sent:
            return False
        sent.remove(data)
        self.echoes_seen += 1
        return True

    def add_rpdo(self, cob_id: int, node_id: int) -> None:
        """Also watch RPDO ``cob_id`` of ``node_id`` (a mapping on a COB-ID of its own).

        Parameters
        ----------
        cob_id : int
            The RPDO's COB-ID.
        node_id : int
            Its node.
        """
        if cob_id not in self._rpdo_node:
            self._rpdo_node[cob_id] = node_id
            self._listen(cob_id)

    def _listen(self, cob_id: int) -> None:
        if cob_id not in self._cobs:
            self._cobs.append(cob_id)
            self._sent.setdefault(cob_id, collections.deque(maxlen=_KEPT))
            self.network.subscribe(cob_id, self._on_frame)

    def _on_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if can_id in self._sdo_requests:  # only to learn whether the bus echoes the host's frames
            self.echoes = self._echo(can_id, bytes(data)) or self.echoes
            return
        if self.echoes and self._echo(can_id, bytes(data)):
            return  # the host's own frame, given back by its adapter
        if can_id == cia.COB_NMT and (len(data) < 2 or data[1] not in self.nodes | {0}):
            return  # an NMT command to other nodes: not this host's business
        with self._lock:
            seen = self.heard.get(can_id)
            if seen is None:
                self.heard[can_id] = [1, timestamp, timestamp, bytes(data)]
            else:
                seen[0] += 1
                seen[2] = timestamp
                seen[3] = bytes(data)
        if can_id != cia.COB_SYNC or self.sync_watched:  # after: a raised alarm finds what was heard
            self.alarm = True

    # --- what was heard, in words ---------------------------------------------------------------
    def _what(self, cob: int) -> str:
        if cob == cia.COB_NMT:
            return "NMT command"
        if cob == cia.COB_SYNC:
            return "SYNC"
        return f"RPDO to node {self._rpdo_node.get(cob, '?')}"

    def _said(self, cob: int, seen: list[Any]) -> str:
        count, first, last, data = seen
        text = f"{self._what(cob)} 0x{cob:03X}"
        if cob == cia.COB_NMT and len(data) >= 2:
            text += f" ({_NMT_WORDS.get(data[0], f'command 0x{data[0]:02X}')} node {data[1] or 'all'})"
        if count > 1 and last > first:
            rate = (count - 1) / (last - first)
            return f"{text} at {rate:.4g} Hz ({count} frames in {last - first:.3g} s)"
        return f"{text} ({count} frame{'s' * (count > 1)})"

    def text(self) -> str:
        """What was heard, COB-ID by COB-ID, in words.

        Returns
        -------
        str
            "" where nothing was.
        """
        with self._lock:
            heard = sorted(self.heard.items())
        return ", ".join(self._said(cob, seen) for cob, seen in heard)

    # --- the checks -----------------------------------------------------------------------------
    def check(
        self,
        window: float,
        *,
        sleep: Callable[[float], None] = time.sleep,
        who: str = "",
        share: bool = True,
    ) -> None:
        """Before anything is enabled: listen until ``window`` [s] have passed since the watch
        began, then ``OtherMaster`` if another master was heard (``who`` names the command;
        ``share``: say that ``[bus] sync = "external"`` shares a SYNC producer). Once passed, a
        SYNC is no longer listened to (the run's own may come from the kernel, or a device).

        Parameters
        ----------
        window : float
            [s] since the watch began to listen before the verdict.
        sleep : Callable[[float], None], optional
            Waits [s] (``time.sleep``).
        who : str, optional
            The command, named in the refusal.
        share : bool, optional
            Say how to share a SYNC producer (``[bus] sync = "external"``).

        Raises
        ------
        OtherMaster
            If another master was heard (what, and when, named).
        """
        left = self.began + window - self._clock()
        if left > 0.0:
            sleep(left)
        if not self.heard:
            self._drop(cia.COB_SYNC)
            return
        advice = "stop the other master (or its run) first"
        if share and cia.COB_SYNC in self.heard:
            advice = f'if that SYNC producer is to pace this rig, set [bus] sync = "external"; else {advice}'
        raise OtherMaster(
            f"{who}another master is on the bus: heard {self.text()}, which this host did not send, in "
            f"{window:.3g} s of listening; nothing was enabled: {advice}"
        )

    def watch_sync(self) -> None:
        """From now on the host produces the SYNC through the network: one heard is another's."""
        self.sync_watched = True
        self._listen(cia.COB_SYNC)

    def intruder(self, node_id: int) -> str | None:
        """While running: an RPDO to ``node_id``, an NMT command to it, or (``watch_sync``) a SYNC
        that the host did not send.

        Parameters
        ----------
        node_id : int
            The node.

        Returns
        -------
        str | None
            What another master sent it, in words; None: nothing.
        """
        heard = self.heard
        if not heard:
            return None
        with self._lock:
            mine = sorted(
                (cob, list(seen))
                for cob, seen in heard.items()
                if self._rpdo_node.get(cob) == node_id
                or (cob == cia.COB_NMT and seen[3][1:2] in (b"\x00", bytes([node_id])))
                or (cob == cia.COB_SYNC and self.sync_watched)
            )
        if not mine:
            return None
        said = ", ".join(self._said(cob, seen) for cob, seen in mine)
        return f"node {node_id}: another master on the bus: {said}, which this host did not send"

    def _drop(self, cob: int) -> None:
        if cob in self._cobs:
            self._cobs.remove(cob)
            if self._on_frame in self.network.subscribers.get(cob, ()):
                self.network.unsubscribe(cob, self._on_frame)

    def close(self) -> None:
        """Stop listening and give the network back its own ``send_message``."""
        for cob in list(self._cobs):
            self._drop(cob)
        if vars(self.network).get("send_message") == self._sending:
            del self.network.send_message  # the network's own again
