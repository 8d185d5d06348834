"""How a cycle starts: SYNC pacing strategies, one small class each.

``tick()`` starts a cycle: it produces the SYNC (or, where the kernel produces
it, waits for the answer to it); when it returns, the feedback of the cycle
has arrived as far as the strategy can know. ``now()`` is the bus clock [s],
the clock the frames' timestamps are on (heartbeat ages are measured on it).

- ``InProcessLockstep``: the emulated world in this process: emulated time from
  a SYNC count, the SYNC delivered synchronously (every TPDO is in before
  ``tick`` returns), in-process Modbus inverters stepped one period.
- ``WireLockstep``: lock-step over a real bus: SYNC, then wait until every
  CANopen axis's TPDOs of this SYNC have arrived (up to ``timeout``).
- ``HostSync``: real time; the host sends SYNC at each deadline.
- ``KernelSync``: real time on SocketCAN; the kernel's broadcast manager sends
  SYNC every period; ``tick`` waits for the answering TPDO.
- ``FreeRun``: real time without SYNC (Modbus-only rigs).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from drivers.canopen_axis import CanopenAxis

__all__ = ["FreeRun", "HostSync", "InProcessLockstep", "KernelSync", "Pacing", "WireLockstep"]


class Pacing:
    """Base: no SYNC, the wall clock; ``paced_by_bus`` means the bus, not the host, keeps the period."""

    paced_by_bus = False

    def tick(self) -> None:
        """Start a cycle."""

    def now(self) -> float:
        """The bus clock [s]."""
        return time.time()

    def close(self) -> None:
        """Stop producing SYNC (idempotent)."""


class FreeRun(Pacing):
    """Real time without a SYNC producer (the loop keeps the deadlines)."""


class InProcessLockstep(Pacing):
    """The in-process emulated world: ``sync()`` sends SYNC on the hub; ``steppers`` advance by a period."""

    def __init__(
        self,
        period: float,
        sync: Callable[[], None] | None,
        steppers: Sequence[Callable[[float], None]] = (),
    ) -> None:
        self.period = period
        self._sync = sync
        self._steppers = list(steppers)
        self.count = 0

    def tick(self) -> None:
        self.count += 1
        for step in self._steppers:
            step(self.period)
        if self._sync is not None:
            self._sync()

    def now(self) -> float:
        return self.count * self.period


class HostSync(Pacing):
    """Real time: the host sends SYNC when the loop's deadline comes."""

    def __init__(self, network: Any) -> None:
        self.network = network

    def tick(self) -> None:
        self.network.sync.transmit()


def _stamps(axes: Sequence[CanopenAxis]) -> list[float | None]:
    return [s for a in axes for s in a.tpdo_stamps()]


class WireLockstep(HostSync):
    """Lock-step over a real bus: SYNC, then wait for every CANopen axis's TPDOs (``timeout`` [s])."""

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], timeout: float) -> None:
        super().__init__(network)
        self.axes = list(axes)
        self.timeout = timeout

    def tick(self) -> None:
        before = _stamps(self.axes)
        self.network.sync.transmit()
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            if all(a != b for a, b in zip(_stamps(self.axes), before)):
                return
            time.sleep(0.0001)


class KernelSync(Pacing):
    """SYNC from the kernel's broadcast manager every ``period`` [s] (SocketCAN); ``tick`` waits
    (up to ``timeout`` [s]) until every CANopen axis has answered the next SYNC."""

    paced_by_bus = True

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], period: float, timeout: float) -> None:
        self.network = network
        self.axes = list(axes)
        self.timeout = timeout
        network.sync.start(period)
        self._running = True

    def tick(self) -> None:
        before = _stamps(self.axes)
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            if all(a != b for a, b in zip(_stamps(self.axes), before)):
                return
            time.sleep(0.00005)

    def close(self) -> None:
        if self._running:
            self._running = False
            self.network.sync.stop()
