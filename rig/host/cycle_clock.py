"""The real-time side of the host loop's cycles (``rig.host.loop``): sleeping to a deadline, the
prime before cycle 0, and young garbage collected in a cycle's slack."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

from drivers.base import AxisDriver
from rig.host.pacing import Pacing
from rig.host.realtime import collect_young
from rig.host.safety import AxisGuard

__all__ = ["collect_in_slack", "missed_periods", "prime", "sleep_until"]


def missed_periods(gap: float, period: float) -> int:
    """SYNC periods [s] skipped between two ticks ``gap`` [s] apart when the bus sets the pace
    (kernel SYNC): the loop skips them and counts them as overruns, so its cycle index, and with it
    the watchdog, keeps to the bus's time."""
    return max(0, round(gap / period) - 1)


def sleep_until(deadline: float, spin: float = 0.0) -> None:
    """Sleep until ``deadline`` (perf_counter s); with ``spin`` [s], until that long before it,
    then spin yielding the GIL (never at real-time priority: ``HostLoop.spin``)."""
    while True:
        left = deadline - time.perf_counter()
        if left <= 0.0:
            return
        time.sleep(left - spin if left > spin + 0.0001 else (0.0 if spin else left))


def prime(
    pacing: Pacing,
    axes: Sequence[AxisDriver],
    guards: Sequence[AxisGuard],
    period: float,
    heartbeat: Callable[[int], None] | None = None,
) -> None:
    """Real time with the host's SYNC: SYNC ``period`` [s] apart until every axis has sent its
    first sample (a TPDO answers a SYNC, after it) and no answer is owed (a drive slow to start
    answers the SYNCs it missed in a burst: cycle 0 does not begin behind it), at most max(1 s,
    the watchdog's time), so cycle 0 reads the drives, not the zeros of TPDOs still to come.
    Answers still owed at the deadline are not awaited by the cycles (the host cannot know
    whether the drive will still send them; logged). ``heartbeat(n)``: the host's, each SYNC."""
    watchdog = max((g.watchdog_periods for g in guards), default=0) * period
    wait = max(1.0, watchdog)
    deadline = time.perf_counter() + wait
    n = 0
    while (not all(axis.has_sample() for axis in axes) or pacing.owes()) and time.perf_counter() < deadline:
        if heartbeat is not None:
            heartbeat(n)
        pacing.tick()
        time.sleep(period)
        n += 1
    if pacing.owes():
        pacing.forget_owed(f"still owed {wait:g} s after the first of {n} SYNCs before cycle 0")


def collect_in_slack(deadline: float, period: float, young: int) -> bool:
    """Where the collector is disabled for real time: the young generations collected once they
    hold ``young`` objects and the next ``deadline`` (perf_counter s) leaves half a ``period``
    [s], so cyclic garbage does not pile up over a long run and no collection runs in a cycle's
    work. True if one ran."""
    return deadline - time.perf_counter() > 0.5 * period and collect_young(young)
