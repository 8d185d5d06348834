"""How a cycle starts: SYNC pacing strategies, one small class each.

``tick()`` starts a cycle: it produces the SYNC (or, where the kernel produces
it, waits for the answer to it); when it returns, the feedback of the cycle
has arrived as far as the strategy can know. ``now()`` is the bus clock [s],
the clock the frames' timestamps are on (heartbeat ages are measured on it).

- ``InProcessLockstep``: the emulated world in this process: emulated time from
  a SYNC count, the SYNC delivered synchronously (every TPDO is in before
  ``tick`` returns), in-process Modbus inverters stepped one period.
- ``HostSync``: the host sends SYNC (in real time at each deadline), then waits until
  every CANopen axis's TPDOs answering it have arrived, up to a budget: the law acts
  on the sample of the same SYNC, as in lock-step. Answers that miss the budget make
  the cycle ``late`` (the loop uses what it has, and counts it). ``split`` gives a cycle's
  response in its two parts: the drives' answer (SYNC to their last TPDO) and the host's own
  time (that TPDO to its RPDOs). During the loop's cycles
  (``owning``), on a bus that lets one thread claim its reading (``claim``/``release``:
  socketcand's), the loop thread reads the frames itself and hands each to the network's
  listeners as the receive thread would (``drivers.owned_receive``): it wakes on the answer
  itself, not after a receive thread has read it and woken it, two thread switches less per cycle.
- ``WireLockstep``: lock-step over a real bus: the same, with a budget as long as the
  transport may need (``timeout``).
- ``KernelSync``: real time on SocketCAN; the kernel's broadcast manager sends
  SYNC every period; ``tick`` waits for the answering TPDO.
- ``ExternalSync``: real time, another device sends SYNC; ``tick`` waits for the
  answering TPDOs.
- ``FreeRun``: real time without SYNC (Modbus-only rigs).
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from drivers.canopen_axis import CanopenAxis
from drivers.owned_receive import OwnedReceive
from rig.host.sync_answers import SyncAnswers, awaited_cob_ids

__all__ = ["ExternalSync", "FreeRun", "HostSync", "InProcessLockstep", "KernelSync", "Pacing", "WireLockstep"]

log = logging.getLogger(__name__)


class Pacing:
    """Base: no SYNC, the wall clock; ``paced_by_bus`` means the bus, not the host, keeps the period."""

    paced_by_bus = False
    sends_sync = False  #: the host's own SYNC, whose answers ``tick`` waits for (``late``)
    late = False  #: the last tick's answers missed their budget
    #: who read the host's CAN bus during the cycles: "receive thread" (python-can's notifier),
    #: "loop thread" (``HostSync.owning``), None (no CAN bus: in process, Modbus only)
    bus_read_by: str | None = None

    def tick(self) -> None:
        """Start a cycle."""

    def now(self) -> float:
        """The bus clock.

        Returns
        -------
        float
            [s] the clock the frames' timestamps are on.
        """
        return time.time()

    def close(self) -> None:
        """Stop producing SYNC (idempotent)."""

    @contextlib.contextmanager
    def owning(self) -> Iterator[None]:
        """While the loop's cycles run (``HostSync``: the loop thread reads the bus itself).

        Yields
        ------
        None
            Inside the cycles.
        """
        yield

    def split(self, done: float) -> tuple[float, float]:
        """The last tick's response as (the drives' answer, the host's own time) (``HostSync``).

        Parameters
        ----------
        done : float
            ``time.perf_counter`` [s] when the cycle's commands were sent.

        Returns
        -------
        tuple[float, float]
            [s]; NaN where the pacing does not send the SYNC, or the answer was late.
        """
        return math.nan, math.nan

    def owes(self) -> bool:
        """Answers to SYNCs already sent are still to come (``HostSync``).

        Returns
        -------
        bool
            True then.
        """
        return False

    def settle(self) -> None:
        """After the last cycle: the answers owed to the host's SYNCs come in (``HostSync``)."""

    def forget_owed(self, why: str) -> None:
        """No answer is owed any more (``HostSync``): where the host cannot know whether the node will
        still send them.

        Parameters
        ----------
        why : str
            The reason, for the log.
        """


class FreeRun(Pacing):
    """Real time without a SYNC producer (the loop keeps the deadlines)."""


class InProcessLockstep(Pacing):
    """The in-process emulated world: each tick steps the ``steppers`` a period, then sends the SYNC.

    Parameters
    ----------
    period : float
        [s] the loop's period.
    sync : Callable[[], None] | None
        Sends SYNC on the hub (None: no CANopen axis).
    steppers : Sequence[Callable[[float], None]]
        Advance a device by the time [s] given (the in-process Modbus inverters).
    """

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
        """The emulated time.

        Returns
        -------
        float
            [s] the SYNCs sent times the period.
        """
        return self.count * self.period


class HostSync(Pacing):
    """The host sends SYNC, then waits for every CANopen axis's TPDOs answering it (module docstring).

    ``late`` when some did not come within ``budget``.

    Parameters
    ----------
    network : Any
        The canopen network.
    axes : Sequence[CanopenAxis]
        The CANopen axes.
    budget : float
        [s] the wait for the answers (``[run] answer_budget``).
    """

    sends_sync = True

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], budget: float) -> None:
        self.network = network
        self.answers = SyncAnswers(network, awaited_cob_ids(axes), owed=True)
        self.budget = budget
        self.late = False  #: the last tick's answers missed the budget
        self.sent_at = 0.0  #: [perf_counter s] the last SYNC sent
        self._reader: OwnedReceive | None = None  #: the loop thread reads the bus (``owning``)
        self.bus_read_by = "receive thread"

    def tick(self) -> None:
        reader = self._reader
        if reader is not None:  # handed on before the arm, as a receive thread would have as it
            reader.arrived()  # came: an answer that came after its tick is not this SYNC's
        self.answers.arm()
        self.sent_at = time.perf_counter()  # as the SYNC is handed to the bus: an answer may beat
        self.network.sync.transmit()  # the return of the send (a bus that delivers at once)
        self.late = not self._answered()

    def _answered(self) -> bool:
        """Wait up to the budget for the answers awaited; True where they all came."""
        reader = self._reader
        if reader is not None:
            return reader.until(self.answers.complete, self.budget)
        return self.answers.wait(self.budget)

    def settle(self) -> None:
        """After the last cycle: the answers still owed to its SYNCs, up to the budget (a late last
        cycle's come after every frame the bus carried before them)."""
        if self.owes():
            self._answered()

    def split(self, done: float) -> tuple[float, float]:
        """The last tick's response in two: the drives' answer and the host's own time.

        The drives' answer is the SYNC sent to the last awaited TPDO handed on, the host's own time
        that TPDO to ``done``.

        Parameters
        ----------
        done : float
            ``time.perf_counter`` [s] when the cycle's commands were sent.

        Returns
        -------
        tuple[float, float]
            [s]; NaN for both where the answer was late.
        """
        answered = self.answers.completed_at
        if self.late or answered < self.sent_at:
            return math.nan, math.nan
        return answered - self.sent_at, done - answered

    def owes(self) -> bool:
        """Answers to SYNCs already sent are still to come (what has come is handed on first).

        Returns
        -------
        bool
            True then.
        """
        if self._reader is not None:
            self._reader.arrived()
        return self.answers.owed()

    def forget_owed(self, why: str) -> None:
        """The answers still owed are not awaited any more (logged with ``why``).

        Should they come, the first cycles take them for their own SYNCs' (acting on older samples,
        not counted late).

        Parameters
        ----------
        why : str
            The reason, for the log.
        """
        owed = self.answers.forget()
        if owed:
            frames = ", ".join(f"{n} on 0x{cob:03X}" for cob, n in sorted(owed.items()))
            log.warning("answers to the host's SYNCs not awaited any more (%s): %s", why, frames)

    @contextlib.contextmanager
    def owning(self) -> Iterator[None]:
        """The calling thread reads the bus itself while the block runs, where the bus allows.

        ``drivers.owned_receive.OwnedReceive``; the receive thread reads again after it.

        Yields
        ------
        None
            Inside the cycles.
        """
        if not OwnedReceive.possible(self.network):
            yield
            return
        reader = OwnedReceive(self.network)
        readers = getattr(self.network.notifier, "_readers", ())
        try:  # a signal that lands in the claim (it waits for the receive thread) gives it back too
            reader.claim(others=any(isinstance(t, threading.Thread) and t.is_alive() for t in readers))
            self._reader = reader
            self.bus_read_by = "loop thread"
            yield
        finally:
            self._reader = None
            reader.release()

    def close(self) -> None:
        self.answers.close()


#: [s] lock-step over a wire waits at least this long for a SYNC's answers: the emulator's time
#: is the SYNCs', so waiting costs no plant time, while acting on a sample that came late would
#: make the run's result depend on the PC's load (docs/emulator.md); a dead emulator is still a
#: stop after the watchdog's periods of this
LOCKSTEP_ANSWER_WAIT = 1.0


class WireLockstep(HostSync):
    """Lock-step over a real bus: ``HostSync`` with the transport's budget, at least ``LOCKSTEP_ANSWER_WAIT``.

    Parameters
    ----------
    network : Any
        The canopen network.
    axes : Sequence[CanopenAxis]
        The CANopen axes.
    budget : float
        [s] the transport's time-out (not the emulated time's).
    """

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], budget: float) -> None:
        super().__init__(network, axes, max(budget, LOCKSTEP_ANSWER_WAIT))


class ExternalSync(Pacing):
    """Another device produces SYNC (``[bus] sync = "external"``); the host sends none.

    ``tick`` waits until every CANopen axis has answered the next SYNC.

    Parameters
    ----------
    network : Any
        The canopen network.
    axes : Sequence[CanopenAxis]
        The CANopen axes.
    timeout : float
        [s] the wait at most.
    """

    paced_by_bus = True

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], timeout: float) -> None:
        self.network = network
        self.bus_read_by = "receive thread"
        self.answers = SyncAnswers(network, awaited_cob_ids(axes))
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
    """SYNC from the kernel's broadcast manager every ``period`` (SocketCAN).

    ``tick`` waits for the answers as ``ExternalSync`` does.

    Parameters
    ----------
    network : Any
        The canopen network, on SocketCAN.
    axes : Sequence[CanopenAxis]
        The CANopen axes.
    period : float
        [s] the SYNC period.
    timeout : float
        [s] the wait at most.
    """

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], period: float, timeout: float) -> None:
        super().__init__(network, axes, timeout)
        network.sync.start(period)

    def close(self) -> None:
        if self._running:
            self.network.sync.stop()
        super().close()
