"""``rig bench stops``'s figures from run summaries (the runs themselves are real-time: the
benchmark's, not a test's): the shares, the spreads, and the CPU time a hypervisor took."""

from __future__ import annotations

from typing import Any

from rig.bench.stops import _figures


def summary(overruns: int, stolen: float | None, stop: str | None = None) -> dict[str, Any]:
    timing = {"period_error_p99_us": 50.0, "response_median_us": 150.0, "response_p99_us": 300.0}
    realtime = {"policy": "SCHED_FIFO", "priority": 50, "cpu": 1, "cpu_stolen_s": stolen}
    return {
        "cycles": 1000 - overruns,
        "overruns": overruns,
        "late_cycles": 0,
        "safe_stop_reason": stop,
        "timing": timing,
        "realtime": realtime,
    }


def figures(summaries: list[dict[str, Any]]) -> dict[str, Any]:
    out = _figures(summaries, period=0.0004, seconds=0.4, load=2, loadavg=("1", "2"), emulator="x")
    return {f["name"]: f["value"] for f in out}


def test_the_stolen_cpu_time_is_given_per_run_in_ms() -> None:
    got = figures([summary(1, 0.01), summary(3, 0.03), summary(2, 0.0)])
    assert got["cpu_stolen_median"] == 10 and got["cpu_stolen_worst"] == 30
    assert got["overruns_median"] == 0.2 and got["overruns_worst"] == 0.3  # % of the cycles
    assert got["false_stops"] == 0


def test_no_stolen_figure_where_a_run_could_not_say() -> None:
    got = figures([summary(1, 0.01), summary(1, None, stop="late")])
    assert "cpu_stolen_median" not in got and got["false_stops"] == 1
