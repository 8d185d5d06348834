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
Times are the device's clock [s].
"""

from __future__ import annotations

from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps.cia import SdoAbortCode

__all__ = ["Deadlines", "HeartbeatConsumer", "check_consumer_entry", "split_consumer_entry"]


def split_consumer_entry(entry: int) -> tuple[int, float]:
    """(node id, time [s]) of a 0x1016 entry; time 0 or node 0 (or > 127): the entry is unused."""
    return (entry >> 16) & 0xFF, (entry & 0xFFFF) / 1000.0  # ms -> s


def check_consumer_entry(entries: dict[int, int], subindex: int, value: int) -> None:
    """SdoAbortedError 0x06040043 if writing ``value`` to 0x1016 sub ``subindex`` would make a
    second active entry for one node (``entries``: the present values by sub-index)."""
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

    def configure(self, times: dict[int, float]) -> None:
        """Monitor these keys from now on (times [s] > 0); a key kept keeps its last time."""
        self.times = {k: t for k, t in times.items() if t > 0.0}
        self._last = {k: t for k, t in self._last.items() if k in self.times}

    def heard(self, key: int, now: float) -> None:
        if key in self.times:
            self._last[key] = now

    def expired(self, now: float) -> list[int]:
        """The monitored keys not heard of within their time; each reported once."""
        late = [k for k, last in self._last.items() if now - last > self.times[k] + 1e-9]
        for k in late:
            del self._last[k]
        return late


class HeartbeatConsumer(Deadlines):
    """0x1016 (see the module docstring): ``configure_entries`` from the object's sub-indices."""

    def configure_entries(self, entries: list[int]) -> None:
        times: dict[int, float] = {}
        for entry in entries:
            node, time = split_consumer_entry(entry)
            if 1 <= node <= 127 and time:
                times[node] = time
        self.configure(times)
