"""Real time for an emulated world: one monotonic clock for every shaft and node.

Without ``--time lockstep``, ``rig emulate`` runs its devices on their own clock, as real
drives run on theirs: ``WorldClock(devices)`` gives every shaft and node the same clock
(time.monotonic from the moment it was made, or an injected one), and ``advance()``,
called often by the emulator's loop, brings every shaft to now (whole periods, each ending
with the drives' own cycles) and runs the nodes' timers (heartbeats, event TPDOs, the
heartbeat consumer and RPDO deadlines). A SYNC then decides when feedback is latched, and
locks the periods' phase to itself (``Shaft.sync``).

In real time the emulator's loop also wakes ``lead`` before each period's end (the next SYNC,
the periods being locked to the SYNCs) and computes that period then (``prepare``): the SYNC
finds its state ready and its TPDOs are a latch and a send, not a computation, as a drive's
firmware answers from the process image it computed ahead.

Before its time starts, the clock has each axis compute what its periods will need
(``Axis.warm``: the DC servo's exact steps, each a matrix exponential), so that no period
computes one under the devices' lock while a SYNC waits for its answer.

An emulator that falls behind (a machine too loaded to run it: its clock read nowhere for
longer than ``max_lag`` [s], where its loop reads it every few ms) does not catch up: the
time it did not run is not its world's time, as a device that was not running sees none
pass. The world stands still over it (``stalled`` [s], logged at most once a second):
nothing is simulated in one go under the lock its receive thread needs, and no timer of
its devices fires for the stall (an RPDO deadline or a heartbeat consumer would otherwise
trip on frames that were waiting in its socket all along), so its heartbeats, timers and
SDO answers go on from where they were. Each shaft also advances at most ``2 max_lag`` of
periods at once (``Shaft.catch_up``).

An emulator whose preparation is already late when it is done (a machine too slow for the
periods: an emulated CPU, a loaded one) still sleeps a lead before it prepares again
(``pause``): its loop runs at real-time priority, and a loop that never sleeps would leave its
receive path (SDO answers, RPDOs, NMT) no CPU at all; the next SYNC is then answered from a state
computed at the SYNC.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence

from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.shaft import Shaft, shafts_of

__all__ = ["LEAD", "WorldClock"]

#: [s] at most, how long before a period's end the emulator computes its state (``prepare``):
#: a period's physics takes tens of microseconds here, and the emulator's loop wakes that early
#: for it
LEAD = 250e-6

log = logging.getLogger(__name__)


class WorldClock:
    """See the module docstring; ``source`` [s] replaces time.monotonic (tests inject one).
    Every reading of ``now`` is under the devices' lock (the emulator's loop, its receive
    path).

    Parameters
    ----------
    devices : Sequence[EmulatedNode]
        The emulated nodes.
    source : Callable[[], float] | None, optional
        [s] the clock read (None: ``time.monotonic``).
    max_lag : float, optional
        [s] a lag beyond which the world stalls (module docstring).
    """

    def __init__(
        self,
        devices: Sequence[EmulatedNode],
        source: Callable[[], float] | None = None,
        *,
        max_lag: float = 0.01,
    ) -> None:
        for shaft in shafts_of(devices):  # what the periods need, computed before time starts
            for axis in shaft.axes:
                axis.warm(shaft.period)
        if source is None:
            start = time.monotonic()

            def source() -> float:
                return time.monotonic() - start

        self._source = source
        self.max_lag = max_lag
        self.stalled = 0.0  #: [s] of the source's time the world stood still
        self._read = source()
        self.devices = list(devices)
        self.shafts: list[Shaft] = shafts_of(self.devices)
        t = self.now()
        for shaft in self.shafts:
            shaft.clock = self.now
            shaft.t = t  # the first period starts now
            shaft.catch_up = max(1, math.ceil(2.0 * max_lag / shaft.period - 1e-9))
        self._reported = 0.0
        self._reported_at = -math.inf
        for d in self.devices:
            d.clock_source = self.now
            d.clock = t

    def now(self) -> float:
        """The world's time [s]: the source's, less the stalls (module docstring).

        Returns
        -------
        float
            [s] the world's time.
        """
        read = self._source()
        gap = read - self._read
        self._read = read
        if gap > self.max_lag:
            self.stalled += gap - self.max_lag
        return read - self.stalled

    @property
    def skipped(self) -> int:
        """Periods skipped behind the clock by the shafts' own bound (``Shaft.catch_up``)."""
        return sum(shaft.skipped for shaft in self.shafts)

    def source(self) -> float:
        """The source's time [s] as it reads (the world's is less the stalls: ``now``).

        Returns
        -------
        float
            [s] the source's time.
        """
        return self._source()

    def lead(self) -> float:
        """[s] how long before a period's end its state is prepared (``prepare``): half the
        shortest period, at most ``LEAD``.

        Returns
        -------
        float
            [s] the lead.
        """
        return min([LEAD, *(0.5 * shaft.period for shaft in self.shafts)])

    def next_boundary(self) -> float:
        """The source's time [s] of the next period end of any shaft (the next SYNC expected:
        the periods are locked to the SYNCs), inf without a shaft.

        Returns
        -------
        float
            [s] the source's time of the next period end; inf without a shaft.
        """
        ends = [shaft.t + shaft.period for shaft in self.shafts]
        return min(ends) + self.stalled if ends else math.inf

    def pause(self, tick: float) -> float:
        """[s] how long the emulator's loop sleeps now: up to the next period's preparation, at
        most ``tick``; one ``lead`` where that preparation is already due when ``prepare`` is
        done (a machine too slow for the periods: the module docstring).

        Parameters
        ----------
        tick : float
            [s] the longest sleep (the loop's tick).

        Returns
        -------
        float
            [s] the sleep, more than 0 and at most ``tick``.
        """
        lead = self.lead()
        wait = self.next_boundary() - lead - self._source()
        return min(tick, wait if wait > 0.0 else lead)

    def prepare(self) -> float:
        """``advance`` with the state at each shaft's next period end computed now where that
        end is within ``lead``: a SYNC then only latches and sends what was prepared, as a
        drive's firmware answers from the process image it computed ahead; now [s].

        Returns
        -------
        float
            [s] now.
        """
        return self.advance(ahead=self.lead())

    def advance(self, *, ahead: float = 0.0) -> float:
        """Bring every shaft and node to now (and each shaft ``ahead`` [s] more, ``prepare``);
        now [s].

        Parameters
        ----------
        ahead : float, optional
            [s] each shaft is brought beyond now.

        Returns
        -------
        float
            [s] now.
        """
        now = self.now()
        for shaft in self.shafts:
            shaft.advance_to(now, ahead=ahead)
        for d in self.devices:
            d.tick(now)
        if self.stalled > self._reported and now - self._reported_at >= 1.0:
            self._reported, self._reported_at = self.stalled, now
            log.warning(
                "the emulator did not run for a while (a loaded machine): its world stood still for "
                "%.0f ms so far",
                self.stalled * 1e3,
            )
        return now
