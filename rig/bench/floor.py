"""The machine's own floor for a real-time period: what a loop that does nothing but sleep to its
deadlines gets, under the host loop's scheduling, in this process.

cyclictest's measure (rt-tests), in Python: with the host loop's real-time request (SCHED_FIFO,
pinned, memory locked, ``rig.host.realtime``) and the collector disabled, sleep to absolute
deadlines ``period`` apart on ``time.perf_counter`` (the loop's own ``sleep_until``) for
``seconds``, and record how late each wake-up was. A wake-up a whole period late or more misses
that many periods, counted as the host loop counts its overruns (``rig.host.loop``). Run beside
``rig bench stops``'s runs, under the same load, it says how much of their period error and
overruns the machine itself gives (its timer wake-ups, other work, a hypervisor's steal) rather
than the toolkit's loop.
"""

from __future__ import annotations

import contextlib
import gc
import time
from collections.abc import Iterator
from typing import Any

from rig.host.cycle_clock import sleep_until
from rig.host.realtime import RealtimeRequest, cpu_stolen, request

__all__ = ["periods_in", "sleep_floor", "under_the_loops_scheduling"]


def periods_in(period: float, seconds: float) -> int:
    """The periods of ``period`` [s] in ``seconds`` [s]; ValueError unless 0 < period <= seconds.

    Parameters
    ----------
    period : float
        [s], > 0.
    seconds : float
        [s], >= ``period``.

    Returns
    -------
    int
        The whole periods in ``seconds``.

    Raises
    ------
    ValueError
        If not 0 < ``period`` <= ``seconds``.
    """
    if not period > 0.0 or not seconds >= period:
        raise ValueError(f"period {period} s, seconds {seconds} s: need 0 < period <= seconds")
    return int(seconds / period)


@contextlib.contextmanager
def under_the_loops_scheduling(ask: RealtimeRequest | None = None) -> Iterator[Any]:
    """Within it: this thread under ``ask`` (the host loop's default request: SCHED_FIFO, pinned,
    memory locked, the PM QoS request) with the collector disabled, as the loop runs; the grant
    (``rig.host.realtime``) is given back and the collector restored after.

    Parameters
    ----------
    ask : RealtimeRequest | None, optional
        The request (None: the host loop's default).

    Yields
    ------
    Any
        The grant (its ``describe()`` says what was granted).
    """
    grant = request(ask or RealtimeRequest())
    enabled = gc.isenabled()
    gc.collect()
    gc.disable()
    try:
        yield grant
    finally:
        if enabled:
            gc.enable()
        grant.release()


def sleep_floor(period: float, seconds: float, ask: RealtimeRequest | None = None) -> dict[str, Any]:
    """Sleep to deadlines ``period`` [s] apart for ``seconds`` [s] under ``ask`` (the host loop's
    default request); ``periods``, ``missed`` (periods), ``lateness_us`` (median, p99, max of the
    wake-ups' lateness), ``cpu_stolen_s`` (None where unknown) and ``granted`` (one line).

    Parameters
    ----------
    period : float
        [s] between deadlines, > 0.
    seconds : float
        [s] of sleeping, >= ``period``.
    ask : RealtimeRequest | None, optional
        The real-time request (None: the host loop's default).

    Returns
    -------
    dict[str, Any]
        ``periods``, ``missed``, ``lateness_us``, ``cpu_stolen_s``, ``granted``.

    Raises
    ------
    ValueError
        If not 0 < ``period`` <= ``seconds``.
    """
    n = periods_in(period, seconds)
    late = [0.0] * n
    with under_the_loops_scheduling(ask) as grant:
        stolen = cpu_stolen()
        woken, missed = _sleep(period, late)
        after = cpu_stolen()
    xs = sorted(late[:woken])
    return {
        "periods": n,
        "missed": missed,
        "lateness_us": _lateness_us(xs),
        "cpu_stolen_s": None if stolen is None or after is None else after - stolen,
        "granted": grant.describe(),
    }


def _sleep(period: float, late: list[float]) -> tuple[int, int]:
    """Sleep to ``len(late)`` deadlines ``period`` [s] apart, each wake-up's lateness [s] written to
    ``late`` in turn; (wake-ups, periods missed: those a late wake-up slept through)."""
    n = len(late)
    k = woken = missed = 0
    deadline = time.perf_counter() + period
    while k < n:
        sleep_until(deadline)
        lateness = time.perf_counter() - deadline
        late[woken] = lateness
        woken += 1
        skipped = int(lateness / period)  # a wake-up that many periods late: those are missed
        missed += min(skipped, n - k - 1)
        k += skipped + 1
        deadline += (skipped + 1) * period
    return woken, missed


def _lateness_us(xs: list[float]) -> dict[str, float]:
    """The median, p99 and max [us] of the sorted latenesses ``xs`` [s]."""
    return {
        "median": xs[len(xs) // 2] * 1e6,
        "p99": xs[int(0.99 * (len(xs) - 1))] * 1e6,
        "max": xs[-1] * 1e6,
    }
