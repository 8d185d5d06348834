"""``rig bench stops``'s figures from run summaries (the runs themselves are real-time: the
benchmark's, not a test's): the shares, the spreads, and the CPU time a hypervisor took."""

from __future__ import annotations

import math
import os
from typing import Any

import pytest

from rig.bench.floor import sleep_floor
from rig.bench.stops import _figures, _floor_figures


def summary(
    overruns: int, stolen: float | None, stop: str | None = None, rms: float = 0.003
) -> dict[str, Any]:
    timing = {"period_error_p99_us": 50.0, "response_median_us": 150.0, "response_p99_us": 300.0}
    realtime = {"policy": "SCHED_FIFO", "priority": 50, "cpu": 1, "cpu_stolen_s": stolen}
    return {
        "cycles": 1000 - overruns,
        "overruns": overruns,
        "late_cycles": 0,
        "safe_stop_reason": stop,
        "rms_error": math.nan if stop else rms,
        "timing": timing,
        "realtime": realtime,
    }


def figures(summaries: list[dict[str, Any]]) -> dict[str, Any]:
    out = _figures(
        summaries, period=0.0004, seconds=0.4, load=2, loadavg=("1", "2"), emulator="x", reference=0.002
    )
    return {f["name"]: f["value"] for f in out}


def test_the_stolen_cpu_time_is_given_per_run_in_ms() -> None:
    got = figures([summary(1, 0.01), summary(3, 0.03), summary(2, 0.0)])
    assert got["cpu_stolen_median"] == 10 and got["cpu_stolen_worst"] == 30
    assert got["overruns_median"] == 0.2 and got["overruns_worst"] == 0.3  # % of the cycles
    assert got["false_stops"] == 0


def test_the_rms_error_is_compared_with_lock_step_s_over_the_runs_that_completed() -> None:
    got = figures([summary(0, 0.0, rms=0.002), summary(0, 0.0, rms=0.004), summary(0, 0.0, stop="late")])
    assert got["rms_lockstep"] == 2.0 and got["rms_error_median"] == 3.0  # mrad
    assert got["rms_ratio_median"] == 1.5 and got["rms_ratio_worst"] == 2.0
    every = figures([summary(0, 0.0, stop="late")])  # no run completed: NaN, never 0
    assert math.isnan(every["rms_error_median"]) and math.isnan(every["rms_ratio_worst"])


def test_no_stolen_figure_where_a_run_could_not_say() -> None:
    got = figures([summary(1, 0.01), summary(1, None, stop="late")])
    assert "cpu_stolen_median" not in got and got["false_stops"] == 1


def test_the_floor_counts_every_period_and_gives_its_scheduling_back() -> None:
    """``sleep_floor`` (the machine's floor beside the runs): every period woken or missed, the
    lateness ordered, the scheduling as before after it (what it measures is the machine's, so
    no figure is checked)."""
    before = (os.sched_getscheduler(0), os.sched_getaffinity(0))
    floor = sleep_floor(0.001, 0.05)
    assert (os.sched_getscheduler(0), os.sched_getaffinity(0)) == before
    assert floor["periods"] == 50 and 0 <= floor["missed"] < 50
    late = floor["lateness_us"]
    assert 0.0 <= late["median"] <= late["p99"] <= late["max"]
    assert floor["granted"]
    figures = {f["name"]: f["value"] for f in _floor_figures(floor)}
    assert figures["floor_missed"] == round(100.0 * floor["missed"] / 50, 3)


def test_the_floor_refuses_a_period_it_cannot_run() -> None:
    with pytest.raises(ValueError, match=r"period 0\.0 s"):
        sleep_floor(0.0, 1.0)
    with pytest.raises(ValueError, match=r"seconds 0\.0001 s"):
        sleep_floor(0.001, 0.0001)


def test_several_loads_merge_their_runs_figure_by_figure() -> None:
    """``--load 0 --load 2``: each load's single-run blocks become one, medians of the runs'
    figures and the worst of the worst, false stops summed and named, prefixed by the load."""
    from rig.bench.stops import _merge

    def block(*summaries: dict[str, Any]) -> list[dict[str, Any]]:
        return _figures(
            list(summaries),
            period=0.0004,
            seconds=0.4,
            load=2,
            loadavg=("1", "2"),
            emulator="x",
            reference=0.002,
        )

    one = [block(summary(1, 0.01, rms=0.002)), block(summary(5, 0.01, stop="late")), block(summary(3, 0.01))]
    merged = {f["name"]: f["value"] for f in _merge(one, 3)}
    assert merged["runs"] == 3 and merged["false_stops"] == 1 and merged["false_stop"] == "late"
    assert merged["overruns_median"] == 0.3 and merged["overruns_worst"] == 0.5  # % of cycles
    assert merged["rms_error_median"] == 2.5 and merged["rms_ratio_worst"] == 1.5  # the stopped run left out


def test_the_cli_takes_several_loads(monkeypatch: pytest.MonkeyPatch) -> None:
    import rig.bench

    seen: dict[str, Any] = {}

    def fake(**kw: Any) -> list[dict[str, Any]]:
        seen.update(kw)
        return []

    monkeypatch.setitem(rig.bench.LONG, "stops", fake)
    from rig.cli import main

    assert main(["bench", "stops", "--load", "0", "--load", "2", "--runs", "1"]) == 0
    assert seen["loads"] == [0, 2] and seen["runs"] == 1


def test_the_round_trip_floor_counts_every_period_and_gives_its_scheduling_back() -> None:
    """``round_trip_floor`` (the machine's floor for a SYNC's answer across processes): a round
    trip to a real echo process each period, ordered, the scheduling as before after it; what it
    measures is the machine's, so no figure is checked."""
    from rig.bench.round_trip import round_trip_floor
    from rig.bench.stops import _trip_figures

    before = (os.sched_getscheduler(0), os.sched_getaffinity(0))
    trip = round_trip_floor(0.001, 0.05)
    assert (os.sched_getscheduler(0), os.sched_getaffinity(0)) == before
    assert trip["periods"] == 50 and trip["granted"]
    rtt = trip["round_trip_us"]
    assert 0.0 < rtt["median"] <= rtt["p99"] <= rtt["max"]
    names = [f["name"] for f in _trip_figures(trip)]
    assert names == ["floor_round_trip_median", "floor_round_trip_p99", "floor_round_trip_max"]
    with pytest.raises(ValueError, match=r"period 0\.001 s, seconds 0\.0001 s"):
        round_trip_floor(0.001, 0.0001)


def test_the_cpu_steadiness_times_the_work_once_a_period_and_gives_its_scheduling_back() -> None:
    """``cpu_steadiness`` (how steady the machine's CPU speed is): one timed call of the fixed work
    per period, the scheduling as before after it, as ``floor_cpu_`` figures in ``rig bench stops``;
    what it measures is the machine's, so no figure is checked."""
    from rig.bench.steadiness import cpu_steadiness
    from rig.bench.stops import _steady_figures

    before = (os.sched_getscheduler(0), os.sched_getaffinity(0))
    steady = cpu_steadiness(0.001, 0.05)
    assert (os.sched_getscheduler(0), os.sched_getaffinity(0)) == before
    assert steady["calls"] == 50 and steady["granted"]
    assert 0.0 < steady["work_us"]["median"] <= steady["work_us"]["p99"] <= steady["work_us"]["max"]
    names = [f["name"] for f in _steady_figures(steady)]
    assert names == [
        "floor_cpu_work_median", "floor_cpu_work_p99", "floor_cpu_slow", "floor_cpu_longest_slow",
    ]  # fmt: skip
    with pytest.raises(ValueError, match=r"period 0\.001 s, seconds 0\.0001 s"):
        cpu_steadiness(0.001, 0.0001)
