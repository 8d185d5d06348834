"""The per-axis guard's watchdog and position check count periods of the loop's cycle index."""

from __future__ import annotations

import types

import pytest

from drivers.base import Feedback
from drivers.errors import SafetyStop
from rig.config import AxisLimits
from rig.host.loop import missed_periods
from rig.host.safety import AxisGuard

PERIOD = 1e-3


def _guard(mode: str = "voltage", **limits: float) -> AxisGuard:
    measures = frozenset({"position", "velocity"})
    names = {"name": "motor", "where": "node 1", "sample_name": "TPDO", "mode": mode}
    axis = types.SimpleNamespace(measures=measures, **names)
    return AxisGuard(axis, AxisLimits(**limits), PERIOD)  # type: ignore[arg-type]


def test_watchdog_counts_the_periods_a_late_tick_spanned() -> None:
    """A bus-paced tick that waited 1,000 SYNC periods for an answer that never came counts as
    1,000 periods without a sample, not one (the vcan tier hung 120 s counting ticks)."""
    guard = _guard(watchdog_periods=1000)
    guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=1.0), 0)
    guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=1.0), 999)  # 999 periods: still in
    with pytest.raises(SafetyStop, match=r"no TPDO for 1000 periods \(1e\+03 ms\)"):
        guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=1.0), 1000)


def test_watchdog_counts_cycles_in_lockstep() -> None:
    guard = _guard(watchdog_periods=3)
    guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=1.0), 0)
    for k in (1, 2):
        guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=1.0), k)
    with pytest.raises(SafetyStop, match="no TPDO for 3 periods"):
        guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=1.0), 3)


def test_watchdog_before_the_first_sample() -> None:
    guard = _guard(watchdog_periods=2)
    guard.check_feedback(Feedback(position=0.0, velocity=0.0), 0)
    with pytest.raises(SafetyStop, match="no TPDO for 2 periods"):
        guard.check_feedback(Feedback(position=0.0, velocity=0.0), 1)


def test_fresh_samples_after_skipped_periods_pass() -> None:
    """Each new sample restarts the count, however many periods it skipped: the watchdog counts
    from the last of them (cycle 500), not from the first."""
    guard = _guard(watchdog_periods=3)
    for stamp, k in enumerate((0, 10, 20, 500)):
        guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=float(stamp)), k)
    guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=3.0), 502)  # the same sample
    with pytest.raises(SafetyStop, match="no TPDO for 3 periods"):
        guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=3.0), 503)


def test_position_step_allowed_per_period() -> None:
    """The speed limit bounds the step per period; over skipped periods the bound grows with them."""
    guard = _guard(speed=100.0)  # max step: 100 rad/s * 1 ms * 3 = 0.3 rad per period
    guard.check_feedback(Feedback(position=0.0, velocity=0.0, stamp=0.0), 0)
    guard.check_feedback(Feedback(position=2.9, velocity=0.0, stamp=1.0), 10)  # 10 periods: 3 rad allowed
    with pytest.raises(SafetyStop, match=r"position jumped by 0.4 rad in 1 period\(s\)"):
        guard.check_feedback(Feedback(position=3.3, velocity=0.0, stamp=2.0), 11)


@pytest.mark.parametrize(
    ("gap", "missed"), [(1.0e-3, 0), (1.4e-3, 0), (1.6e-3, 1), (2.0e-3, 1), (1.0, 999), (0.2e-3, 0)]
)
def test_missed_periods(gap: float, missed: int) -> None:
    assert missed_periods(gap, PERIOD) == missed


def test_a_stall_is_not_a_position_jump() -> None:
    """The drive stalled (its process held up): the host saw the same sample for 40 cycles, then
    one 40 periods of motion further on. The step is bounded by the periods since the last new
    sample, not since the last repeat (the link-drop scenario stopped on "position jumped by
    2.2 rad in 1 period")."""
    guard = _guard(speed=100.0, watchdog_periods=100)  # 0.3 rad a period
    guard.check_feedback(Feedback(position=0.0, velocity=50.0, stamp=0.0), 0)
    for k in range(1, 41):
        guard.check_feedback(Feedback(position=0.0, velocity=50.0, stamp=0.0), k)  # repeated
    guard.check_feedback(Feedback(position=2.0, velocity=50.0, stamp=1.0), 41)  # 41 periods on
    with pytest.raises(SafetyStop, match=r"position jumped by 0.4 rad in 1 period\(s\)"):
        guard.check_feedback(Feedback(position=2.4, velocity=50.0, stamp=2.0), 42)


def test_the_position_command_step_counts_the_periods_since_the_last_command() -> None:
    """A real-time cycle after a late one (the loop's index jumped 3 periods) commands the
    reference of its own time: 3 periods of motion on from the last command. The step is bounded
    by the periods between the commands, as the feedback's is by the periods between the samples
    (issue 33: CSP runs stopped themselves on 'position command steps 0.93 rad (> 0.9 rad a
    period)' after a late cycle). Within one period the same step is still a stop."""
    guard = _guard("csp", speed=100.0, command=100.0)  # 0.3 rad a period
    guard.check_feedback(Feedback(position=0.0, velocity=90.0, stamp=0.0), 0)
    guard.check_command(0.09, 0)  # 0.09 rad from the measured position in 1 period
    guard.check_command(0.18, 1)
    guard.check_command(0.18 + 0.8, 4)  # a late cycle: 3 periods on, 0.8 rad < 0.9 rad
    step = r"steps 0\.8 rad from the last command in 1 period\(s\) \(> 0\.3 rad"
    with pytest.raises(SafetyStop, match=step):
        guard.check_command(0.98 + 0.8, 5)


def test_the_first_position_command_counts_the_periods_since_the_sample() -> None:
    """The first command is checked against the measured position, over the periods since that
    sample was taken (at least one)."""
    guard = _guard("csp", speed=100.0, command=100.0)
    guard.check_feedback(Feedback(position=1.0, velocity=0.0, stamp=0.0), 0)
    with pytest.raises(SafetyStop, match=r"steps 0\.5 rad from the measured position in 1 period\(s\)"):
        guard.check_command(1.5, 0)
    other = _guard("csp", speed=100.0, command=100.0)
    other.check_feedback(Feedback(position=1.0, velocity=0.0, stamp=0.0), 0)
    other.check_command(1.5, 2)  # two periods after the sample: 0.6 rad allowed
