"""A host and a device that disagree about time, found before any motor moves.

A device keeps time one of two ways, and its heartbeat (CiA 301, 0x1017) shows which: a real
drive, or ``rig emulate`` in real time, beats on its own clock whether SYNCs come or not; a
device whose time is the SYNCs' (``rig emulate --time lockstep``) beats only as SYNCs make its
time pass. A lock-step host needs the second kind (its SYNC is the step of time), a real-time
host the first (its drives must stop themselves if it dies, on their own clock).

``TimeModeProbe`` is attached before the set-up: it subscribes to each CANopen axis's
heartbeat COB-ID and is told of every SYNC the host sends meanwhile (``synced``). ``check``,
after the set-up and before the enable, decides for each node with a producer heartbeat time
(read from 0x1017; a node without one is not judged):

- lock-step host: a heartbeat (not the boot-up) that came ``QUIET`` s or more after the host's
  last SYNC means the node keeps its own time;
- real-time host: no heartbeat at all over twice its producer time (and ``QUIET``) means the
  node's time stands still without SYNC.

Where the set-up did not last that long without SYNC, ``check`` waits the rest (a few tenths of a
second). A disagreement is one ``ConfigError`` naming the node, the host's mode and the flag to
change.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from drivers.errors import ConfigError, RigError

__all__ = ["QUIET", "TimeModeProbe"]

log = logging.getLogger(__name__)

QUIET = 0.25  #: [s] a heartbeat this long after the host's last SYNC was not made by a SYNC
_PRODUCER_HEARTBEAT = 0x1017
_BOOT_UP = 0


class TimeModeProbe:
    """A host and a device that disagree about time (module docstring).

    Parameters
    ----------
    network : Any
        The CANopen network (its heartbeats subscribed to).
    axes : Sequence[Any]
        The CANopen axes (``node_id``, ``sdo_read``, ``where``).
    """

    def __init__(self, network: Any, axes: Sequence[Any]) -> None:
        self.network = network
        self.axes = list(axes)
        self._lock = threading.Lock()
        self.start = time.monotonic()
        self.last_sync: float | None = None  #: [s, monotonic] the host's last SYNC
        self.beats: dict[int, list[tuple[float, float | None]]] = {}  #: node -> (when, last SYNC then)
        self._subscribed: list[tuple[int, Any]] = []
        for axis in self.axes:
            node = axis.node_id
            self.beats[node] = []

            def on_beat(can_id: int, data: bytearray, ts: float, node: int = node) -> None:
                if data and data[0] != _BOOT_UP:
                    with self._lock:
                        self.beats[node].append((time.monotonic(), self.last_sync))

            network.subscribe(0x700 + node, on_beat)
            self._subscribed.append((0x700 + node, on_beat))

    def synced(self) -> None:
        """The host has just sent a SYNC."""
        with self._lock:
            self.last_sync = time.monotonic()

    def sending(self, sync: Callable[[], None]) -> Callable[[], None]:
        """``sync`` (a SYNC of the set-up's), noted as it is sent.

        Parameters
        ----------
        sync : Callable[[], None]
            Sends a SYNC.

        Returns
        -------
        Callable[[], None]
            Sends it and notes it (`synced`).
        """

        def send() -> None:
            sync()
            self.synced()

        return send

    def close(self) -> None:
        """Unsubscribe from the heartbeats (idempotent; `check` does it too)."""
        for cob, callback in self._subscribed:
            if callback in self.network.subscribers.get(cob, ()):
                self.network.unsubscribe(cob, callback)
        self._subscribed.clear()

    def _producer(self, axis: Any) -> float:
        """The node's producer heartbeat time [s] (0: none, or not readable)."""
        try:
            return float(axis.sdo_read(_PRODUCER_HEARTBEAT, 0)) / 1000.0
        except (RigError, TypeError, ValueError) as exc:
            log.debug("%s: producer heartbeat time not read: %s", axis.where, exc)
            return 0.0

    def check(self, *, lockstep: bool) -> None:
        """Judge each node with a producer heartbeat time against the host's time (module docstring).

        Parameters
        ----------
        lockstep : bool
            The host's time is the SYNCs' (else real time).

        Raises
        ------
        ConfigError
            Naming the node, the host's mode and the flag to change.
        """
        try:
            for axis in self.axes:
                producer = self._producer(axis)
                if producer > 0.0:
                    self._judge(axis.node_id, producer, lockstep)
        finally:
            self.close()

    def _quiet_since(self) -> float:
        with self._lock:
            return self.start if self.last_sync is None else self.last_sync

    def _judge(self, node: int, producer: float, lockstep: bool) -> None:
        window = max(2.0 * producer, QUIET) + 0.05
        wait = self._quiet_since() + window - time.monotonic()
        if lockstep:
            if not self._own_clock(node) and wait > 0.0:
                time.sleep(wait)
            if self._own_clock(node):
                raise ConfigError(
                    f"node {node} keeps its own time (its heartbeat came without a SYNC), but this run is in "
                    'lock-step ([run] time = "lockstep"), where time is the SYNCs\': set [run] time = '
                    '"realtime", or start the emulator with rig emulate --time lockstep'
                )
            return
        if not self.beats[node] and wait > 0.0:
            time.sleep(wait)
        if not self.beats[node]:
            raise ConfigError(
                f"node {node} sent no heartbeat in {window:.2g} s although its producer heartbeat time "
                f"(0x1017) is {producer * 1000:g} ms: its time stands still without SYNC, as rig emulate "
                '--time lockstep keeps it, but this run is in real time ([run] time = "realtime"): start '
                'rig emulate without --time lockstep, or set [run] time = "lockstep"'
            )

    def _own_clock(self, node: int) -> bool:
        """A heartbeat of ``node`` came ``QUIET`` s or more after the host's last SYNC before it."""
        with self._lock:
            beats = list(self.beats[node])
        return any(sync is None or when - sync >= QUIET for when, sync in beats)
