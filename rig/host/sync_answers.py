"""The answers a cycle awaits after a SYNC: one frame on each TPDO COB-ID that answers every SYNC
(``rig.host.pacing``'s ``HostSync``, ``ExternalSync`` and ``KernelSync`` wait on them)."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from typing import Any

from drivers.canopen_axis import CanopenAxis
from drivers.maps.cia import PDO_SYNC_MAX

__all__ = ["SyncAnswers", "awaited_cob_ids"]

log = logging.getLogger(__name__)


class SyncAnswers:
    """Waits for one frame on each of ``cob_ids``: a subscriber per COB-ID on ``network``.

    ``arm()`` before the SYNC (or the wait), ``wait(timeout)`` until every COB-ID has sent a frame
    since, or ``timeout``. The receive thread wakes the waiter at once.

    With ``owed`` (the host's SYNC): a TPDO carries no SYNC number, but a node answers the SYNCs in
    order, so an answer that missed its cycle (still awaited when the next SYNC is armed) is owed:
    the next frame on that COB-ID is taken for it, the one after for the new SYNC. Every answer owed
    is carried over: after a stall of n periods, a cycle is on time only once the whole burst of n
    answers has come, so it acts on the answer to its own SYNC; a cycle with part of the burst is
    late (docs/time.md). A frame the node never sends (lost) is taken for late ever after and ends
    in the late-cycle stop, named as such; CAN does not lose frames it acknowledged, nor TCP. Where
    the host cannot know whether the node will still answer (the prime's SYNCs, unanswered at its
    end), ``forget`` clears the debt.

    Parameters
    ----------
    network : Any
        The canopen network subscribed to.
    cob_ids : Sequence[int]
        The COB-IDs awaited (`awaited_cob_ids`).
    owed : bool
        Carry the answers owed over to the next SYNC.
    """

    def __init__(self, network: Any, cob_ids: Sequence[int], *, owed: bool = False) -> None:
        self.network = network
        self.cob_ids = frozenset(cob_ids)
        self.carry = owed
        self._pending: dict[int, int] = {}  #: COB-ID -> frames still awaited
        self._waiting = 0  #: COB-IDs with frames still awaited
        #: [perf_counter s] when the last awaited frame was handed on (the answer complete)
        self.completed_at = 0.0
        self._done = threading.Condition()
        for cob in self.cob_ids:
            network.subscribe(cob, self._on_frame)

    def arm(self) -> None:
        """A frame is awaited on each COB-ID (and, with ``owed``, those still owed)."""
        with self._done:
            if self.carry:
                self._pending = {cob: self._pending.get(cob, 0) + 1 for cob in self.cob_ids}
            else:
                self._pending = dict.fromkeys(self.cob_ids, 1)
            self._waiting = len(self._pending)

    def _on_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._done:
            n = self._pending.get(can_id, 0)
            if n:
                self._pending[can_id] = n - 1
                if n == 1:
                    self._waiting -= 1
                    if not self._waiting:
                        self.completed_at = time.perf_counter()
                        self._done.notify_all()

    def complete(self) -> bool:
        """Every awaited frame has come.

        Returns
        -------
        bool
            True then.
        """
        return not self._waiting

    def owed(self) -> bool:
        """Frames are awaited (since the last ``arm``, or owed from before it).

        Returns
        -------
        bool
            True then.
        """
        return any(self._pending.values())

    def forget(self) -> dict[int, int]:
        """No frame is awaited any more.

        Returns
        -------
        dict[int, int]
            What was: COB-ID -> frames.
        """
        with self._done:
            owed = {cob: n for cob, n in self._pending.items() if n}
            self._pending = {}
            self._waiting = 0
            return owed

    def wait(self, timeout: float) -> bool:
        """Wait until every awaited frame has come, or ``timeout``.

        Parameters
        ----------
        timeout : float
            [s] at most.

        Returns
        -------
        bool
            True where they all came.
        """
        with self._done:
            return self._done.wait_for(lambda: not self._waiting, timeout)

    def close(self) -> None:
        """Unsubscribe (idempotent)."""
        for cob in self.cob_ids:
            if self._on_frame in self.network.subscribers.get(cob, ()):
                self.network.unsubscribe(cob, self._on_frame)


def awaited_cob_ids(axes: Sequence[CanopenAxis]) -> list[int]:
    """The COB-IDs awaited after each SYNC: the TPDOs that answer every SYNC.

    The others are not awaited (logged): a node sends them on every n-th SYNC from a start the host
    does not know, or on an event, so a cycle cannot know which SYNC they answer.

    Parameters
    ----------
    axes : Sequence[CanopenAxis]
        The CANopen axes, their mapping in force.

    Returns
    -------
    list[int]
        Their TPDOs' COB-IDs.
    """
    for a in axes:
        for cob, ttype in a.tpdos_not_awaited():
            kind = f"every n-th SYNC, n = {ttype}" if 1 < ttype <= PDO_SYNC_MAX else "acyclic or event-driven"
            log.warning(
                "%s: TPDO 0x%03X has transmission type %d (%s): the cycles do not wait for it, and"
                " its sample may be older than their SYNC (make it 1 to have it awaited)",
                a.where,
                cob,
                ttype,
                kind,
            )
    return [cob for a in axes for cob in a.tpdo_cob_ids()]
