"""The CiA 406 encoder's speed by difference of positions: over the time between the two samples."""

from __future__ import annotations

import math

import canopen
import pytest

from drivers.cia402 import Cia402Axis
from drivers.cia406 import Cia406Axis
from plant_emulator.lockstep import LockstepBench


def test_a_sample_after_skipped_cycles_gives_the_speed_not_a_multiple_of_it() -> None:
    """The host reads every third SYNC's sample (two cycles skipped, as a real-time host's
    overruns skip them): the backward difference spans three periods. Dividing by one period
    gave three times the speed (a false over-speed stop on the real-time dyno)."""
    bench = LockstepBench("dc-servo")
    drive = Cia402Axis("motor", bench.host, 1, mode="voltage")
    encoder = Cia406Axis("encoder", bench.host, 2, period=bench.period, speed_from_position=True)
    try:
        for axis in (drive, encoder):
            axis.setup()
        drive.enable()
        for _ in range(1500):  # 0.6 s at 2 V: near its steady 85 rad/s (a_m = 16 1/s)
            drive.command(2.0)
            bench.sync()
        shaft = bench.devices[0].shaft  # type: ignore[attr-defined]
        speeds = []
        for _ in range(10):
            for _ in range(3):
                bench.sync()
            speeds.append((encoder.feedback().velocity, shaft.velocity))
        for measured, true in speeds[1:]:
            assert measured == pytest.approx(true, rel=0.03)  # a count over 1.2 ms is 1.3 rad/s
    finally:
        for axis in (drive, encoder):
            axis.close()
        bench.close()


def test_the_time_between_samples_is_whole_periods_on_the_grid_else_the_stamps() -> None:
    encoder = Cia406Axis("encoder", canopen.Network(), 2, period=4e-4)
    last = 3 * 4e-4
    assert encoder._elapsed(last, 6 * 4e-4) == 3 * 4e-4  # lock-step stamps: exact whole periods
    assert encoder._elapsed(last, 3 * 4e-4 + 1.3e-4) == pytest.approx(1.3e-4)  # a late SYNC before
    assert encoder._elapsed(last, None) == encoder._elapsed(last, 1e-4) == 4e-4  # the stamps cannot tell
    assert math.isclose(encoder._elapsed(last, 3 * 4e-4 + 9.1e-4), 9.1e-4)
    encoder._forget()  # never set up: nothing to close on the device
