"""Real time for an emulated world: one monotonic clock for every shaft and node.

Without ``--time lockstep``, ``rig emulate`` runs its devices on their own clock, as real
drives run on theirs: ``WorldClock(devices)`` gives every shaft and node the same clock
(time.monotonic from the moment it was made, or an injected one), and ``advance()``,
called often by the emulator's loop, brings every shaft to now (whole periods, each ending
with the drives' own cycles) and runs the nodes' timers (heartbeats, event TPDOs, the
heartbeat consumer and RPDO deadlines). A SYNC then decides when feedback is latched, and
locks the periods' phase to itself (``Shaft.sync``).

An emulator that falls behind its clock (a machine too loaded to simulate the periods in
time) does not simulate the backlog in one go under the lock its receive thread needs:
each shaft advances at most the periods of ``max_lag`` [s] at once and skips the earlier
ones (the plant holds still over them), counted in ``skipped`` and logged (at most once a
second), so its heartbeats, timers and SDO answers stay on time.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence

from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.shaft import Shaft

__all__ = ["WorldClock"]

log = logging.getLogger(__name__)


class WorldClock:
    """See the module docstring; ``source`` [s] replaces time.monotonic (tests inject one)."""

    def __init__(
        self,
        devices: Sequence[EmulatedNode],
        source: Callable[[], float] | None = None,
        *,
        max_lag: float = 0.02,
    ) -> None:
        if source is None:
            start = time.monotonic()

            def source() -> float:
                return time.monotonic() - start

        self.now = source
        self.devices = list(devices)
        shafts = [getattr(d, "shaft", None) for d in self.devices]
        self.shafts: list[Shaft] = list({id(s): s for s in shafts if s is not None}.values())
        t = source()
        for shaft in self.shafts:
            shaft.clock = source
            shaft.t = t  # the first period starts now
            shaft.catch_up = max(1, math.ceil(max_lag / shaft.period - 1e-9))
        self._reported = 0
        self._reported_at = -math.inf
        for d in self.devices:
            d.clock_source = source
            d.clock = t

    @property
    def skipped(self) -> int:
        """Periods skipped behind the clock, over every shaft."""
        return sum(shaft.skipped for shaft in self.shafts)

    def advance(self) -> float:
        """Bring every shaft and node to now; now [s]."""
        now = self.now()
        for shaft in self.shafts:
            shaft.advance_to(now)
        for d in self.devices:
            d.tick(now)
        skipped = self.skipped
        if skipped > self._reported and now - self._reported_at >= 1.0:
            self._reported, self._reported_at = skipped, now
            log.warning(
                "the emulator fell behind its clock: %d period(s) skipped so far (the plant held still)",
                skipped,
            )
        return now
