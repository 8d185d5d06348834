"""Real time for an emulated world: one monotonic clock for every shaft and node.

Without ``--time lockstep``, ``rig emulate`` runs its devices on their own clock, as real
drives run on theirs: ``WorldClock(devices)`` gives every shaft and node the same clock
(time.monotonic from the moment it was made, or an injected one), and ``advance()``,
called often by the emulator's loop, brings every shaft to now (whole periods, each ending
with the drives' own cycles) and runs the nodes' timers (heartbeats, event TPDOs, the
heartbeat consumer and RPDO deadlines). A SYNC then only decides when feedback is latched.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.shaft import Shaft

__all__ = ["WorldClock"]


class WorldClock:
    """See the module docstring; ``source`` [s] replaces time.monotonic (tests inject one)."""

    def __init__(self, devices: Sequence[EmulatedNode], source: Callable[[], float] | None = None) -> None:
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
        for d in self.devices:
            d.clock_source = source
            d.clock = t

    def advance(self) -> float:
        """Bring every shaft and node to now; now [s]."""
        now = self.now()
        for shaft in self.shafts:
            shaft.advance_to(now)
        for d in self.devices:
            d.tick(now)
        return now
