"""``rig bench view``'s figures from the runs' summaries (the runs themselves are the benchmark's:
minutes of real-time runs, not run by the tests)."""

from __future__ import annotations

from rig.bench.view import _kind_figures


def _summary(answer_p99: float, host_p99: float, stop: str | None = None) -> dict[str, object]:
    timing = {
        "period_error_p99_us": 40.0,
        "response_median_us": 170.0,
        "response_p99_us": answer_p99 + host_p99,
        "drive_answer_p99_us": answer_p99,
        "host_time_p99_us": host_p99,
    }
    return {"cycles": 9990, "overruns": 10, "late_cycles": 20, "timing": timing, "safe_stop_reason": stop}


def test_each_kind_gives_the_response_and_its_two_parts() -> None:
    """The response's p99 and its parts, the drive's answer and the host's own time, each as the
    median and range over the runs: where the view's cost falls (the emulated drive's CPU, or the
    toolkit's own process) is read from them."""
    runs = [_summary(150.0, 90.0), _summary(170.0, 110.0), _summary(210.0, 100.0, "device fault")]
    got = {f["name"]: f["value"] for f in _kind_figures("remote", runs)}
    assert got["remote_drive_answer_p99_median"] == 170.0 and got["remote_host_time_p99_median"] == 100.0
    assert got["remote_drive_answer_p99_range"] == "150.0 .. 210.0"
    assert got["remote_response_p99_median"] == 280.0 and got["remote_stops"] == 1
    assert got["remote_overruns_median"] == 0.1  # 10 of 10,000 cycles


def test_the_remote_reader_stands_in_at_sched_idle() -> None:
    """The remote reader's process takes only the CPU time nothing else wants (SCHED_IDLE, as a
    reader on another machine takes none of the rig PC's), its children with it."""
    import os
    import subprocess
    import sys

    from rig.bench.view import as_if_elsewhere

    code = "import os, sys, time; sys.stdin.readline(); print(os.sched_getscheduler(0))"
    pipe = subprocess.PIPE
    reader = subprocess.Popen([sys.executable, "-c", code], stdin=pipe, stdout=pipe, text=True)
    as_if_elsewhere(reader.pid)
    out, _ = reader.communicate("go\n", timeout=30)
    assert int(out) == os.SCHED_IDLE
