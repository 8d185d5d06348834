"""How steady this machine's CPU speed is: the same small piece of Python work, run once a period
under the host loop's scheduling, timed each time.

A CPU whose speed does not change runs the same code in nearly the same time, period after
period, give or take its caches. A virtual machine's vCPU need not: a hypervisor that shares the
physical core with another machine (SMT siblings) or changes its frequency makes the same work
take 1.5-2 times as long for stretches of tens to hundreds of ms, and nothing inside the machine
shows it (the steal time counts only a vCPU that was not running at all). Every cycle of the host
loop and every answer of an emulated drive is such work, so a machine that runs it that slowly in
a share of its periods gives their p99 that much above their median, whatever the toolkit does
(docs/time.md gives this machine's figures).

``cpu_steadiness`` sleeps to deadlines ``period`` apart as ``rig.bench.floor.sleep_floor`` does,
under the same request, and at each wake-up times ``_work`` (a fixed loop of float additions and a
dict, a few microseconds: the kind of work a cycle does); ``slow_episodes`` says how often it took
``SLOW`` times its median or more, and how long the longest run of such periods lasted.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Sequence
from typing import Any

from rig.bench.floor import periods_in, under_the_loops_scheduling
from rig.host.cycle_clock import sleep_until
from rig.host.realtime import RealtimeRequest

__all__ = ["SLOW", "cpu_steadiness", "described", "slow_episodes"]

SLOW = 1.5  #: a call this many times the median or more is slow
_ROUNDS = 300  #: float additions per call of the work (about 10 us here)
_SHARES = ("slow_share", "slow_after_slow", "longest_slow_ms")


def _work() -> dict[str, float]:
    """The fixed work timed each period."""
    total = 0.0
    for i in range(_ROUNDS):
        total += i * 0.5
    return {"total": total}


def slow_episodes(durations: Sequence[float], period: float) -> dict[str, Any]:
    """How often ``durations`` (each period's, in order) were ``SLOW`` times their median or more.

    Parameters
    ----------
    durations : Sequence[float]
        [s] the work's duration in each period, in order.
    period : float
        [s] between two of them.

    Returns
    -------
    dict[str, Any]
        ``calls``; ``work_us`` (median, p99, max); ``slow_share`` (of the calls);
        ``slow_after_slow`` (the share of slow calls among those right after a slow one: near
        ``slow_share`` for scattered ones, near 1 for episodes; NaN without a slow call);
        ``longest_slow_ms`` (the longest run of consecutive slow calls, in periods' time).
    """
    xs = sorted(durations)
    n = len(xs)
    if n == 0:
        nan = float("nan")  # nothing measured: no figure, not 0
        work = dict.fromkeys(("median", "p99", "max"), nan)
        return {"calls": 0, "work_us": work} | dict.fromkeys(_SHARES, nan)
    median = xs[n // 2]
    slow = [d >= SLOW * median for d in durations]
    pairs = sum(1 for a, _ in itertools.pairwise(slow) if a)
    after = sum(1 for a, b in itertools.pairwise(slow) if a and b)
    run = longest = 0
    for s in slow:
        run = run + 1 if s else 0
        longest = max(longest, run)
    return {
        "calls": n,
        "work_us": {"median": median * 1e6, "p99": xs[int(0.99 * (n - 1))] * 1e6, "max": xs[-1] * 1e6},
        "slow_share": sum(slow) / n,
        "slow_after_slow": after / pairs if pairs else float("nan"),
        "longest_slow_ms": longest * period * 1e3,
    }


def cpu_steadiness(period: float, seconds: float, ask: RealtimeRequest | None = None) -> dict[str, Any]:
    """The fixed work once every ``period`` [s] for ``seconds`` [s] under ``ask`` (the host loop's
    default request): ``slow_episodes`` of its durations, and ``granted`` (one line).

    Parameters
    ----------
    period : float
        [s] between two calls, > 0.
    seconds : float
        [s] in all, >= ``period``.
    ask : RealtimeRequest | None, optional
        The real-time request (None: the host loop's default).

    Returns
    -------
    dict[str, Any]
        ``slow_episodes``'s figures and ``granted``.

    Raises
    ------
    ValueError
        If not 0 < ``period`` <= ``seconds``.
    """
    durations = [0.0] * periods_in(period, seconds)
    with under_the_loops_scheduling(ask) as grant:
        clock = time.perf_counter
        deadline = clock() + period
        for k in range(len(durations)):
            sleep_until(deadline)
            start = clock()
            _work()
            durations[k] = clock() - start
            deadline = max(deadline + period, clock())  # a late wake-up does not crowd the next calls
    return slow_episodes(durations, period) | {"granted": grant.describe()}


def described(steady: dict[str, Any]) -> str:
    """``cpu_steadiness``'s figures in one line.

    Parameters
    ----------
    steady : dict[str, Any]
        ``cpu_steadiness``'s result.

    Returns
    -------
    str
        The line.
    """
    work = steady["work_us"]
    return (
        f"the same {work['median']:.0f} us of work took 1.5 times that or more in "
        f"{100 * steady['slow_share']:.3g} % of {steady['calls']} periods (p99 {work['p99']:.0f} us), "
        f"in runs of up to {steady['longest_slow_ms']:.3g} ms"
    )
