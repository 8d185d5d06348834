"""A lean process image (an axis's ``feedback``): the TPDOs carry only what the law reads, the
speed is then the position's backward difference; a bad ``feedback`` is one error at load."""

from __future__ import annotations

import pathlib

import pytest

from drivers.cia402 import Cia402Axis
from drivers.errors import ConfigError
from plant_emulator.lockstep import LockstepBench
from rig.config import load_config

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position_rt.toml"


def _run(feedback: tuple[str, ...]) -> tuple[list[tuple[int, int]], list[tuple[float, float]]]:
    """The drive's TPDOs as (COB-ID, bytes), and (read speed, true speed) over 10 cycles at 2 V."""
    bench = LockstepBench("dc-servo", {"period": 0.0004})
    drive = Cia402Axis("motor", bench.host, 1, mode="voltage", period=bench.period, feedback=feedback)
    try:
        drive.setup()
        drive.enable()
        for _ in range(1500):  # 0.6 s at 2 V: near its steady 85 rad/s
            drive.command(2.0)
            bench.sync()
        shaft = bench.devices[0].shaft  # type: ignore[attr-defined]
        speeds = []
        for _ in range(10):
            drive.command(2.0)
            bench.sync()
            speeds.append((drive.feedback().velocity, shaft.velocity))
        assert drive.data is not None
        return [(s.cob_id, s.codec.size) for s in drive.data.slots], speeds
    finally:
        drive.close()
        bench.close()


def test_the_lean_image_is_one_tpdo_of_statusword_and_position_and_the_speed_by_difference() -> None:
    tpdos, speeds = _run(("position",))
    assert tpdos == [(0x181, 6)]  # 0x6041 (2 bytes) and 0x6064 (4 bytes)
    for measured, true in speeds[1:]:  # a count (2 pi / 4096) over 0.4 ms is 3.8 rad/s
        assert measured == pytest.approx(true, abs=4.0)
    full, _ = _run(("position", "velocity", "mode", "torque", "current"))
    assert sum(n for _, n in full) > 6 and len(full) == 2  # the default: as before, two TPDOs


def test_the_example_maps_the_lean_image() -> None:
    assert load_config(EXAMPLE).axes[0].feedback == ("position",)


@pytest.mark.parametrize(
    ("value", "needle"),
    [
        ('["velocity"]', "feedback = ['velocity']: position and any of velocity, mode, torque, current"),
        ('["position", "speed"]', "feedback = ['position', 'speed']: position and any of"),
        ('"position"', "feedback = 'position': expected a list"),
    ],
)
def test_a_bad_feedback_is_one_error_naming_file_axis_key_and_value(
    tmp_path: pathlib.Path, value: str, needle: str
) -> None:
    path = tmp_path / "rig.toml"
    path.write_text(EXAMPLE.read_text().replace('feedback = ["position"]', f"feedback = {value}"))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value).startswith(f"{path}: [[axis]] 'motor'") and needle in str(err.value)


def test_feedback_on_an_axis_that_cannot_choose_it_is_refused(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "rig.toml"
    text = EXAMPLE.read_text().replace('kind = "cia402"', 'kind = "cia406"').replace('mode = "voltage"\n', "")
    path.write_text(text)
    refused = r"feedback = \['position'\]: a key of cia402 axes, not of kind cia406"
    with pytest.raises(ConfigError, match=refused):
        load_config(path)


def test_the_driver_checks_it_too() -> None:
    bench = LockstepBench("dc-servo")
    try:
        with pytest.raises(ConfigError, match=r"axis 'motor': feedback = \['torque'\]"):
            Cia402Axis("motor", bench.host, 1, mode="voltage", feedback=("torque",))
    finally:
        bench.close()
