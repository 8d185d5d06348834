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
- ``ExternalSync``: real time, another device sends SYNC; ``tick`` waits for the
  answering TPDOs.
- ``FreeRun``: real time without SYNC (Modbus-only rigs).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from drivers.canopen_axis import CanopenAxis

__all__ = ["ExternalSync", "FreeRun", "HostSync", "InProcessLockstep", "KernelSync", "Pacing", "WireLockstep"]


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


class _Answers:
    """Waits for one frame on each of ``cob_ids``: a subscriber per COB-ID on ``network``.

    ``arm()`` before the SYNC (or the wait), ``wait(timeout)`` until every COB-ID has sent
    a frame since, or ``timeout`` [s]. The receive thread wakes the waiter at once.
    """

    def __init__(self, network: Any, cob_ids: Sequence[int]) -> None:
        self.network = network
        self.cob_ids = frozenset(cob_ids)
        self._pending: set[int] = set()
        self._done = threading.Condition()
        for cob in self.cob_ids:
            network.subscribe(cob, self._on_frame)

    def arm(self) -> None:
        with self._done:
            self._pending = set(self.cob_ids)

    def _on_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._done:
            self._pending.discard(can_id)
            if not self._pending:
                self._done.notify_all()

    def wait(self, timeout: float) -> bool:
        with self._done:
            return self._done.wait_for(lambda: not self._pending, timeout)

    def close(self) -> None:
        for cob in self.cob_ids:
            if self._on_frame in self.network.subscribers.get(cob, ()):
                self.network.unsubscribe(cob, self._on_frame)


def _cob_ids(axes: Sequence[CanopenAxis]) -> list[int]:
    return [cob for a in axes for cob in a.tpdo_cob_ids()]


class WireLockstep(HostSync):
    """Lock-step over a real bus: SYNC, then wait for every CANopen axis's TPDOs (``timeout`` [s])."""

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], timeout: float) -> None:
        super().__init__(network)
        self.answers = _Answers(network, _cob_ids(axes))
        self.timeout = timeout

    def tick(self) -> None:
        self.answers.arm()
        self.network.sync.transmit()
        self.answers.wait(self.timeout)

    def close(self) -> None:
        self.answers.close()


class ExternalSync(Pacing):
    """Another device produces SYNC (``[bus] sync = "external"``): ``tick`` waits (up to
    ``timeout`` [s]) until every CANopen axis has answered the next SYNC; the host sends none."""

    paced_by_bus = True

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], timeout: float) -> None:
        self.network = network
        self.answers = _Answers(network, _cob_ids(axes))
        self.timeout = timeout
        self._running = True

    def tick(self) -> None:
        self.answers.arm()
        self.answers.wait(self.timeout)

    def close(self) -> None:
        if self._running:
            self._running = False
            self.answers.close()


class KernelSync(ExternalSync):
    """SYNC from the kernel's broadcast manager every ``period`` [s] (SocketCAN); ``tick`` waits
    for the answers as ``ExternalSync`` does."""

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], period: float, timeout: float) -> None:
        super().__init__(network, axes, timeout)
        network.sync.start(period)

    def close(self) -> None:
        if self._running:
            self.network.sync.stop()
        super().close()
