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
from drivers.maps.cia import PDO_SYNC_MAX
from drivers.owned_receive import OwnedReceive

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
        """The bus clock [s]."""
        return time.time()

    def close(self) -> None:
        """Stop producing SYNC (idempotent)."""

    @contextlib.contextmanager
    def owning(self) -> Iterator[None]:
        """While the loop's cycles run (``HostSync``: the loop thread reads the bus itself)."""
        yield

    def split(self, done: float) -> tuple[float, float]:
        """The last tick's response as (the drives' answer, the host's own time) [s] (``HostSync``);
        NaN where the pacing does not send the SYNC."""
        return math.nan, math.nan

    def owes(self) -> bool:
        """Answers to SYNCs already sent are still to come (``HostSync``)."""
        return False

    def forget_owed(self, why: str) -> None:
        """No answer is owed any more (``HostSync``); ``why``: the reason, for the log."""


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


class _Answers:
    """Waits for one frame on each of ``cob_ids``: a subscriber per COB-ID on ``network``.

    ``arm()`` before the SYNC (or the wait), ``wait(timeout)`` until every COB-ID has sent
    a frame since, or ``timeout`` [s]. The receive thread wakes the waiter at once.

    ``owed`` (the host's SYNC): a TPDO carries no SYNC number, but a node answers the SYNCs
    in order, so an answer that missed its cycle (still awaited when the next SYNC is armed)
    is owed: the next frame on that COB-ID is taken for it, the one after for the new SYNC.
    Every answer owed is carried over: after a stall of n periods, a cycle is on time only
    once the whole burst of n answers has come, so it acts on the answer to its own SYNC; a
    cycle with part of the burst is late. (Carrying one at most, as a first version did, the
    cycles after a stall of two periods or more acted on samples that many periods old and
    were not counted late.) A frame the node never sends (lost) is taken for late ever after
    and ends in the late-cycle stop, named as such; CAN does not lose frames it acknowledged,
    nor TCP. Where the host cannot know whether the node will still answer (the prime's
    SYNCs, unanswered at its end), ``forget`` clears the debt.
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
        """Every awaited frame has come."""
        return not self._waiting

    def owed(self) -> bool:
        """Frames are awaited (since the last ``arm``, or owed from before it)."""
        return any(self._pending.values())

    def forget(self) -> dict[int, int]:
        """No frame is awaited any more; returns what was (COB-ID -> frames)."""
        with self._done:
            owed = {cob: n for cob, n in self._pending.items() if n}
            self._pending = {}
            self._waiting = 0
            return owed

    def wait(self, timeout: float) -> bool:
        with self._done:
            return self._done.wait_for(lambda: not self._waiting, timeout)

    def close(self) -> None:
        for cob in self.cob_ids:
            if self._on_frame in self.network.subscribers.get(cob, ()):
                self.network.unsubscribe(cob, self._on_frame)


def _cob_ids(axes: Sequence[CanopenAxis]) -> list[int]:
    """The COB-IDs awaited after each SYNC: the TPDOs that answer every SYNC. The others are not
    awaited (logged): a node sends them on every n-th SYNC from a start the host does not know,
    or on an event, so a cycle cannot know which SYNC they answer."""
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


class HostSync(Pacing):
    """The host sends SYNC, then waits up to ``budget`` [s] for every CANopen axis's TPDOs
    answering it; ``late`` when some did not come in time (see the module docstring)."""

    sends_sync = True

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], budget: float) -> None:
        self.network = network
        self.answers = _Answers(network, _cob_ids(axes), owed=True)
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
        if reader is not None:
            self.late = not reader.until(self.answers.complete, self.budget)
        else:
            self.late = not self.answers.wait(self.budget)

    def split(self, done: float) -> tuple[float, float]:
        """The last tick's response in two [s]: the drives' answer (the SYNC sent to the last
        awaited TPDO handed on) and the host's own time (that TPDO to ``done``, the
        perf_counter time its commands were sent); NaN for both where the answer was late."""
        answered = self.answers.completed_at
        if self.late or answered < self.sent_at:
            return math.nan, math.nan
        return answered - self.sent_at, done - answered

    def owes(self) -> bool:
        """Answers to SYNCs already sent are still to come (what has come is handed on first)."""
        if self._reader is not None:
            self._reader.arrived()
        return self.answers.owed()

    def forget_owed(self, why: str) -> None:
        """The answers still owed are not awaited any more (logged with ``why``): where the host
        cannot know whether the node will still send them. Should they come, the first cycles
        take them for their own SYNCs' (acting on older samples, not counted late)."""
        owed = self.answers.forget()
        if owed:
            frames = ", ".join(f"{n} on 0x{cob:03X}" for cob, n in sorted(owed.items()))
            log.warning("answers to the host's SYNCs not awaited any more (%s): %s", why, frames)

    @contextlib.contextmanager
    def owning(self) -> Iterator[None]:
        """The calling thread reads the bus itself while the block runs, where the bus allows
        (``OwnedReceive``); the receive thread reads again after it."""
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
#: make the run's result depend on the PC's load (a 0.1 s wait under a load of 10 on 2 cores:
#: rms 1.984 mrad, not the 1.983 of every quiet run); a dead emulator is still a stop after
#: the watchdog's periods of this
LOCKSTEP_ANSWER_WAIT = 1.0


class WireLockstep(HostSync):
    """Lock-step over a real bus: ``HostSync`` with a budget of ``timeout`` [s] (the transport's,
    not the emulated time's), at least ``LOCKSTEP_ANSWER_WAIT``."""

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], budget: float) -> None:
        super().__init__(network, axes, max(budget, LOCKSTEP_ANSWER_WAIT))


class ExternalSync(Pacing):
    """Another device produces SYNC (``[bus] sync = "external"``): ``tick`` waits (up to
    ``timeout`` [s]) until every CANopen axis has answered the next SYNC; the host sends none."""

    paced_by_bus = True

    def __init__(self, network: Any, axes: Sequence[CanopenAxis], timeout: float) -> None:
        self.network = network
        self.bus_read_by = "receive thread"
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
