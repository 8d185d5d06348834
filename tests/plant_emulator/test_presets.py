"""Preset parameters: typed values by name, checked names, types and ranges."""

from __future__ import annotations

import math

import canopen
import pytest

from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.lockstep import LockstepBench
from plant_emulator.presets import (
    PRESETS,
    DcServoPreset,
    build_preset,
    preset_params,
    preset_period,
)


def test_typed_values_by_name_with_or_without_the_plant_prefix() -> None:
    p = preset_params("dc-servo", {"a_m": 20.0, "plant.b_m": 500, "load": "const:0.1", "drive_node": 5})
    assert (p.a_m, p.b_m, p.load, p.drive_node) == (20.0, 500.0, "const:0.1", 5)
    assert isinstance(p.b_m, float)  # an int is fine for a float field, and becomes one
    assert preset_params("dc-servo", None) == DcServoPreset()
    assert preset_period("grid-converter", {"ratio": 1 / 20}) == pytest.approx(1 / 1000)
    assert preset_params("grid-converter", {"strategy": "s-pwm-middle"}).strategy == "s-pwm-middle"


def test_unknown_parameter_names_it_and_the_known_ones() -> None:
    with pytest.raises(ValueError, match=r"'a_n' unknown; known: a_m, b_m, r_r"):
        preset_params("dc-servo", {"a_n": 1.0})
    with pytest.raises(ValueError, match="unknown preset 'dc'; known: dc-servo"):
        preset_params("dc", {})


@pytest.mark.parametrize(
    "name,value,expected",
    [
        ("a_m", "16", "expected float, got str"),
        ("counts_per_rev", 4096.0, "expected int, got float"),
        ("drive_node", True, "expected int, got bool"),
        ("friction", None, "expected float, got NoneType"),
        ("load", 0.0, "expected str, got float"),
    ],
)
def test_a_value_of_the_wrong_type_names_name_value_and_type(name: str, value: object, expected: str) -> None:
    with pytest.raises(ValueError, match=f"{name}={value!r}: {expected}"):
        preset_params("dc-servo", {name: value})


def test_a_choice_outside_its_literal() -> None:
    with pytest.raises(
        ValueError, match=r"strategy='s-pwm-end': expected one of 's-pwm-start', 's-pwm-middle'"
    ):
        preset_params("grid-converter", {"strategy": "s-pwm-end"})


@pytest.mark.parametrize(
    "preset,params,match",
    [
        ("dc-servo", {"period": 0.0}, r"period = 0.0: must be a period of 1e-05 \.\. 10 s"),
        ("dc-servo", {"period": math.nan}, "period = nan: must be a period of"),
        ("dc-servo", {"counts_per_rev": 0}, r"counts_per_rev = 0: must be 1 \.\. 2147483647 increments/rev"),
        ("dc-servo", {"friction": -1e-3}, "friction = -0.001: must be >= 0 N m s/rad"),
        ("dc-servo", {"drive_node": 128}, r"drive_node = 128: must be 1 \.\. 127"),
        ("dc-servo", {"encoder_node": 1}, "encoder_node = 1: is also drive_node"),
        ("dc-servo", {"load": "ramp:1"}, "load = 'ramp:1': profile 'ramp:1'"),
        ("im-drive", {"max_speed_rpm": -5}, r"max_speed_rpm = -5: must be 1 \.\. 4294967295 rpm"),
        ("grid-converter", {"u_line_rms": -1.0}, "u_line_rms = -1.0: must be >= 0 V"),
        ("grid-converter", {"drive_node": 0}, r"drive_node = 0: must be 1 \.\. 127"),
        ("dyno", {"motor": "pmsm"}, "motor='pmsm': expected one of 'dc', 'im'"),
        ("dyno", {"load_node": 2}, "load_node = 2: is also encoder_node"),
        ("dyno", {"j_load": -1e-4}, r"j_load = -0\.0001: must be >= 0 kg m\^2"),
        ("dyno", {"load_rated_torque": 0.0}, "load_rated_torque = 0.0: must be > 0 N m"),
        ("dyno", {"rated_current": None, "max_speed_rpm": 0}, r"max_speed_rpm = 0: must be 1 \.\."),
        ("dyno", {"load": "pulse:5:2"}, "load = 'pulse:5:2': profile 'pulse:5:2'"),
    ],
)
def test_out_of_range_values_name_the_field_and_value(
    preset: str, params: dict[str, object], match: str
) -> None:
    with pytest.raises(ValueError, match=match):
        preset_params(preset, params)


def test_a_keys_range_is_the_schemas_and_a_rule_between_keys_the_dataclasses() -> None:
    """A key's own range and choices are its field's metadata, checked once with the values given
    (``with_params``, as the loader does); the rules between keys are the dataclass's own."""
    with pytest.raises(ValueError, match="strategy='x': expected one of"):
        preset_params("grid-converter", {"strategy": "x"})
    with pytest.raises(ValueError, match=r"rated_current = 0\.0: must be > 0 A"):
        preset_params("dc-servo", {"rated_current": 0.0})
    with pytest.raises(ValueError, match="encoder_node = 1"):
        DcServoPreset(encoder_node=1)


def test_build_and_bench_take_typed_values_and_refuse_text() -> None:
    devices, period = build_preset("dc-servo", canopen.Network(), {"drive_node": 7, "encoder_node": 8})
    assert [d.node_id for d in devices] == [7, 8] and period == 0.4e-3
    with pytest.raises(ValueError, match="u_line_rms='0': expected float"):
        LockstepBench("grid-converter", {"u_line_rms": "0"})
    bench = LockstepBench("grid-converter", {"u_line_rms": 0.0})
    assert bench.period == pytest.approx(1 / 1350)
    bench.close()


def test_dyno_ratings_default_to_the_motor_under_tests() -> None:
    devices, _ = build_preset(
        "dyno", canopen.Network(), {"motor": "im", "load_rated_torque": 8, "j_load": 1e-3}
    )
    motor, _, load = devices
    assert [motor.read(i) for i in (0x6075, 0x6076, 0x6073, 0x6080)] == [4596, 5000, 2500, 3600]
    assert [load.read(i) for i in (0x6075, 0x6076, 0x6073, 0x6080)] == [4596, 8000, 3000, 3600]
    assert motor.axis.p.j == pytest.approx(0.0035 + 1e-3)  # type: ignore[attr-defined]
    devices, _ = build_preset("dyno", canopen.Network(), {"rated_current": 5.0})
    k_t = DCMotorParams.from_am_bm(a_m=16.0, b_m=680.0, b=DcServoPreset().friction).k_t  # B within a_m
    assert [devices[0].read(i) for i in (0x6075, 0x6076)] == [5000, round(k_t * 5 * 1000)]


def test_every_preset_builds_with_its_defaults() -> None:
    for name in PRESETS:
        devices, period = build_preset(name, canopen.Network())
        assert devices and period == preset_period(name)
