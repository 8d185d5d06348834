"""How an emulated CANopen device watches its peers (CiA 301): heartbeat consumer and RPDO deadlines.

- Heartbeat consumer, 0x1016: each sub-index n holds ``node id << 16 | time [ms]``;
  the device expects a heartbeat of that node within that time of the previous
  one. Monitoring of a node starts with its first heartbeat (a node that never
  beat is not missed) and, after a loss was reported, starts again with the
  next heartbeat. Two entries for one node are refused (SDO abort 0x06040043).
- RPDO deadline, the event timer (sub 5) of an RPDO's communication parameter
  [ms]: an RPDO that does not come again within it is a timeout, reported once
  until the next one arrives (CiA 301 7.5.2.35; 0 switches it off).

The device's reaction (EMCY 0x8130 / 0x8250, the NMT state of 0x1029, the
drive's 0x6007) is the node's and the drive's; this module only keeps time.
Times are the device's clock [s]: a frame counts from the instant it came (``heard_now``),
and the watch is checked at each SYNC and tick of the node and, on a drive in real time,
at the end of each period of its own clock (``EmulatedDrive.on_period``), so a loss is
found within a period of its deadline, as firmware checks it each cycle.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
from drivers.maps.cia import (
    COB_HEARTBEAT,
    EmcyCode,
    ErrorBehavior,
    ErrorRegister,
    NmtState,
    SdoAbortCode,
)

__all__ = ["Deadlines", "HeartbeatConsumer", "Supervision", "check_consumer_entry", "split_consumer_entry"]

log = logging.getLogger(__name__)
PRE_OPERATIONAL, OPERATIONAL, STOPPED = (
    int(NmtState.PRE_OPERATIONAL),
    int(NmtState.OPERATIONAL),
    int(NmtState.STOPPED),
)


def split_consumer_entry(entry: int) -> tuple[int, float]:
    """(node id, time [s]) of a 0x1016 entry; time 0 or node 0 (or > 127): the entry is unused.

    Parameters
    ----------
    entry : int
        A 0x1016 entry.

    Returns
    -------
    tuple[int, float]
        (node id, time [s]).
    """
    return (entry >> 16) & 0xFF, (entry & 0xFFFF) / 1000.0  # ms -> s


def check_consumer_entry(entries: dict[int, int], subindex: int, value: int) -> None:
    """SdoAbortedError 0x06040043 if writing ``value`` to 0x1016 sub ``subindex`` would make a
    second active entry for one node (``entries``: the present values by sub-index).

    Parameters
    ----------
    entries : dict[int, int]
        The present entries by sub-index.
    subindex : int
        The entry written.
    value : int
        Its new value.

    Raises
    ------
    SdoAbortedError
        0x06040043, if it makes a second active entry for a node.
    """
    node, time = split_consumer_entry(value)
    if not node or not time:
        return
    for sub, other in entries.items():
        other_node, other_time = split_consumer_entry(other)
        if sub != subindex and other_node == node and other_time:
            raise SdoAbortedError(SdoAbortCode.PARAMETER_INCOMPATIBLE)


class Deadlines:
    """Keys (nodes, RPDO numbers) that must be heard of within their own time [s]."""

    def __init__(self) -> None:
        self.times: dict[int, float] = {}  #: key -> allowed silence [s]
        self._last: dict[int, float] = {}  #: key -> when it was last heard [s] (monitored keys)
        #: [s] no key expires before this (a lower bound: hearing a key only moves its deadline on)
        self.due = -math.inf

    def configure(self, times: dict[int, float]) -> None:
        """Monitor these keys from now on (times [s] > 0); a key kept keeps its last time.

        Parameters
        ----------
        times : dict[int, float]
            Key -> [s] > 0.
        """
        self.times = {k: t for k, t in times.items() if t > 0.0}
        self._last = {k: t for k, t in self._last.items() if k in self.times}
        self.due = -math.inf

    def heard(self, key: int, now: float) -> None:
        """Key ``key`` was heard of at ``now`` [s].

        Parameters
        ----------
        key : int
            The key (a node id, an RPDO).
        now : float
            [s] the device time.
        """
        if key in self.times:
            if key not in self._last:
                self.due = min(self.due, now + self.times[key])
            self._last[key] = now

    def expired(self, now: float) -> list[int]:
        """The monitored keys not heard of within their time; each reported once.

        Parameters
        ----------
        now : float
            [s] the device time.

        Returns
        -------
        list[int]
            The keys expired.
        """
        if now <= self.due:  # every SYNC asks: most of the time nothing can have expired yet
            return []
        times = self.times
        late = [k for k, last in self._last.items() if now - last > times[k] + 1e-9]
        for k in late:
            del self._last[k]
        self.due = min((last + times[k] + 1e-9 for k, last in self._last.items()), default=math.inf)
        return late


class HeartbeatConsumer(Deadlines):
    """0x1016 (see the module docstring): ``configure_entries`` from the object's sub-indices."""

    def configure_entries(self, entries: list[int]) -> None:
        """Monitor the heartbeats that 0x1016's ``entries`` name (unused entries skipped).

        Parameters
        ----------
        entries : list[int]
            The 0x1016 entries.
        """
        times: dict[int, float] = {}
        for entry in entries:
            node, time = split_consumer_entry(entry)
            if 1 <= node <= 127 and time:
                times[node] = time
        self.configure(times)


class Supervision:
    """The supervising part of ``EmulatedNode`` (a mixin): the consumer's configuration from
    0x1016, the losses it and the RPDO deadlines find, and what a loss does (see the module
    docstring)."""

    node_id: int
    node: Any
    od: Any
    network: Any
    clock: float
    clock_source: Callable[[], float] | None
    heartbeats: HeartbeatConsumer
    rpdo_deadlines: Deadlines
    _consumed: list[int]

    if TYPE_CHECKING:  # the node's own, used here

        @property
        def nmt_state(self) -> int: ...
        def emcy(self, code: int, register: int, data: bytes = b"") -> None: ...
        def on_abort_connection(self, what: str, code: int) -> None: ...

    def supervise(self, now: float) -> None:
        """Report the heartbeats and RPDOs lost by ``now`` [s] (asked every SYNC: most of the time
        nothing can have expired yet, which costs a comparison each).

        Parameters
        ----------
        now : float
            [s] the device time.
        """
        if now > self.heartbeats.due:
            for node in self.heartbeats.expired(now):
                self.communication_error(f"heartbeat of node {node} lost", EmcyCode.HEARTBEAT)
        if now > self.rpdo_deadlines.due:
            for number in self.rpdo_deadlines.expired(now):
                self.communication_error(f"RPDO{number + 1} timed out", EmcyCode.RPDO_TIMEOUT)

    def heard_now(self) -> float:
        """The device time [s] a frame heard now is stamped with: the instant it came on the
        emulator's clock in real time (not the latest tick's, which may be a loaded loop's several
        ms earlier and would trip a deadline early), the latest SYNC's in lock-step.

        Returns
        -------
        float
            [s] the device time.
        """
        return self.clock if self.clock_source is None else self.clock_source()

    def communication_error(self, what: str, code: int) -> None:
        """A lost heartbeat or RPDO: EMCY ``code``, the drive's reaction, then the NMT state of 0x1029.

        Parameters
        ----------
        what : str
            What was lost, in words.
        code : int
            The EMCY code.
        """
        log.warning("node %d: %s", self.node_id, what)
        self.emcy(code, ErrorRegister.GENERIC | ErrorRegister.COMMUNICATION)
        self.on_abort_connection(what, code)
        if cia.ERROR_BEHAVIOR not in self.node.object_dictionary:
            return
        behavior = self.od.read(cia.ERROR_BEHAVIOR, 1)
        if behavior == ErrorBehavior.PRE_OPERATIONAL and self.nmt_state == OPERATIONAL:
            self.node.nmt._state = PRE_OPERATIONAL
        elif behavior == ErrorBehavior.STOPPED:
            self.node.nmt._state = STOPPED

    def _on_consumed_heartbeat(self, can_id: int, data: bytes, timestamp: float) -> None:
        self.heartbeats.heard(can_id - COB_HEARTBEAT, self.heard_now())

    def _consumer_entries(self) -> dict[int, int]:
        """The sub-indices 1-n of 0x1016 (none where the device has no heartbeat consumer)."""
        if cia.CONSUMER_HEARTBEAT not in self.node.object_dictionary:
            return {}
        count = self.od.read(cia.CONSUMER_HEARTBEAT, 0)
        return {s: self.od.read(cia.CONSUMER_HEARTBEAT, s) for s in range(1, count + 1)}

    def _configure_consumer(self) -> None:
        self.heartbeats.configure_entries(list(self._consumer_entries().values()))
        for cob in self._consumed:
            self.network.unsubscribe(cob, self._on_consumed_heartbeat)
        self._consumed = [COB_HEARTBEAT + node for node in self.heartbeats.times]
        for cob in self._consumed:
            self.network.subscribe(cob, self._on_consumed_heartbeat)
