"""A speed-commanded axis's speed against its command in a run (``rig.host.motion_check``): a shaft
that turns the other way or at a multiple of the command without coming towards it stops the run
within its window; a step, a reversal and a drive's ripple do not."""

from __future__ import annotations

import math

import pytest

from drivers.errors import SafetyStop
from rig.host.motion_check import FollowCheck

PERIOD = 0.001  #: [s]: the window is 50 periods


def _check() -> FollowCheck:
    return FollowCheck("motor, node 1", PERIOD, speed_limit=200.0, quantum=0.1)


def _run(check: FollowCheck, commands: list[float], speeds: list[float]) -> int:
    """Cycles until the stop (the count of all where none)."""
    for k, (cmd, v) in enumerate(zip(commands, speeds, strict=True)):
        try:
            check.see(v)
        except SafetyStop:
            return k
        check.sent(cmd)
    return len(commands)


@pytest.mark.parametrize(
    ("factor", "said"),
    [(-1.0, "turns the other way"), (9.55, "9.55 times it")],  # 9.55: rpm taken for rad/s
)
def test_a_steady_disagreement_stops_within_its_window(factor: float, said: str) -> None:
    check = _check()
    with pytest.raises(SafetyStop, match=said) as err:
        for _ in range(200):
            check.sent(50.0)
            check.see(50.0 * factor)
    assert "against a command of 50 rad/s" in str(err.value)
    stopped = _run(_check(), [50.0] * 200, [50.0 * factor] * 200)
    assert stopped == 50  # the first sample answers no command; the next 50 are its window


def test_a_reversal_along_the_drive_s_ramp_goes_on() -> None:
    """+100 rad/s to -100 rad/s at 2,000 rad/s^2: 100 ms the other way, coming towards it."""
    commands = [100.0] * 50 + [-100.0] * 300
    speeds, v = [], 100.0
    for cmd in commands:
        speeds.append(v)
        v = max(cmd, v - 2.0) if cmd < v else min(cmd, v + 2.0)
    assert _run(_check(), commands, speeds) == len(commands)


def test_a_step_down_with_a_slow_ramp_goes_on() -> None:
    commands = [100.0] * 20 + [5.0] * 1000
    speeds, v = [], 100.0
    for cmd in commands:
        speeds.append(v)
        v = max(cmd, v - 0.1)  # 100 rad/s^2: a second above twice the command
    assert _run(_check(), commands, speeds) == len(commands)


def test_ripple_and_coarse_units_go_on() -> None:
    commands = [20.0] * 500
    speeds = [20.0 + 12.0 * math.sin(0.3 * k) for k in range(500)]  # within 2 x 20 + 4 + 0.2 + 10
    assert _run(_check(), commands, speeds) == len(commands)
