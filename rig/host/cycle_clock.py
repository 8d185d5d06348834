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
    """SYNC periods skipped between two ticks when the bus sets the pace (kernel SYNC).

    The loop skips them and counts them as overruns, so its cycle index, and with it the watchdog,
    keeps to the bus's time.

    Parameters
    ----------
    gap : float
        The time between the two ticks [s].
    period : float
        The SYNC period [s].

    Returns
    -------
    int
        The periods skipped (0 or more).
    """
    return max(0, round(gap / period) - 1)


def sleep_until(deadline: float, spin: float = 0.0) -> None:
    """Sleep until ``deadline``; with ``spin``, until that long before it, then spin yielding the GIL.

    Parameters
    ----------
    deadline : float
        ``time.perf_counter`` time [s].
    spin : float
        How long to spin [s] (never at real-time priority: ``HostLoop.spin``).
    """
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
    """Real time with the host's SYNC: SYNCs until every axis has its first sample and nothing is owed.

    A TPDO answers a SYNC, after it; a drive slow to start answers the SYNCs it missed in a burst,
    so cycle 0 does not begin behind it, and reads the drives, not the zeros of TPDOs still to come.
    At most max(1 s, the watchdog's time); answers still owed then are not awaited by the cycles
    (the host cannot know whether the drive will still send them; logged).

    Parameters
    ----------
    pacing : Pacing
        The run's pacing (it ticks the SYNC).
    axes : Sequence[AxisDriver]
        The loop's axes.
    guards : Sequence[AxisGuard]
        Their guards (the watchdog's periods).
    period : float
        The loop's period [s].
    heartbeat : Callable[[int], None] | None
        The host's heartbeat, given each SYNC's index (None: none).
    """
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
    """Collect the young generations in a cycle's slack, where the collector is disabled for real time.

    Once they hold ``young`` objects and the next deadline leaves half a period, so cyclic garbage
    does not pile up over a long run and no collection runs in a cycle's work.

    Parameters
    ----------
    deadline : float
        The next cycle's ``time.perf_counter`` time [s].
    period : float
        The loop's period [s].
    young : int
        The objects the young generations hold before they are collected.

    Returns
    -------
    bool
        True if a collection ran.
    """
    return deadline - time.perf_counter() > 0.5 * period and collect_young(young)
