"""A cycle's share of the bus: the real-time example's lean image fits a 1 Mbit/s bus at the
paper's 0.4 ms with margin, the full one does not and is warned, naming period, bit rate and
objects; the example runs the paper's servo in lock-step (deterministic: no load, no clock)."""

from __future__ import annotations

import dataclasses
import logging
import pathlib

import pytest

from rig.config import RigConfig, load_config
from rig.host.bus_load import bus_load, warn_bus_load
from rig.host.session import Session

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
PERIOD = 0.0004  #: [s] the paper's (section VII.B)


def _lockstep(name: str, out: pathlib.Path) -> RigConfig:
    cfg = load_config(EXAMPLES / name)
    return dataclasses.replace(
        cfg, run=dataclasses.replace(cfg.run, time="lockstep", period=PERIOD, output=str(out))
    )


def _figures(name: str, out: pathlib.Path) -> dict[str, object]:
    """The bus figures of example ``name``'s mapping in force (set up on the emulated drive)."""
    with Session(_lockstep(name, out), emulate=True, duration=PERIOD) as session:
        session.start()
        return bus_load(session.axes, PERIOD, 1_000_000)  # type: ignore[arg-type]


def test_the_lean_image_fits_the_paper_period_on_1_mbit(
    tmp_path: pathlib.Path, caplog: pytest.LogCaptureFixture
) -> None:
    figures = _figures("dc_servo_position_rt.toml", tmp_path)
    # SYNC 55, TPDO (0x6041 0x6064: 6 bytes) 115, RPDO (0x6040 and the voltage: 6 bytes) 115
    assert figures["bits_per_cycle"] == 285 and figures["load"] == pytest.approx(0.7125)
    assert figures["frames"] == [
        "SYNC 0x080: 0 B, 55 bits",
        "node 1 TPDO1 0x181 (0x6041 0x6064): 6 B, 115 bits",
        "node 1 RPDO1 0x201 (0x6040 0x2100): 6 B, 115 bits",
    ]
    with caplog.at_level(logging.WARNING, logger="rig.host.bus_load"):
        assert not warn_bus_load(figures)
    assert not caplog.records


def test_the_full_image_at_the_paper_period_is_warned_naming_period_bitrate_and_objects(
    tmp_path: pathlib.Path, caplog: pytest.LogCaptureFixture
) -> None:
    figures = _figures("dc_servo_position.toml", tmp_path)
    assert figures["bits_per_cycle"] == 430 and figures["load"] == pytest.approx(1.075)
    with caplog.at_level(logging.WARNING, logger="rig.host.bus_load"):
        assert warn_bus_load(figures)
    (record,) = caplog.records
    text = record.getMessage()
    for needle in ("430 bit times", "108 %", "0.0004 s", "1000 kbit/s", "0x606C", "[[axis]] feedback"):
        assert needle in text, (needle, text)


def test_the_example_runs_the_paper_servo_in_lockstep(tmp_path: pathlib.Path) -> None:
    with Session(_lockstep("dc_servo_position_rt.toml", tmp_path), emulate=True) as session:
        session.start()
        summary = session.run()
    assert summary["cycles"] == 7500 and summary["safe_stop_reason"] is None and summary["stop_confirmed"]
    assert summary["rms_error"] < 0.005, summary["rms_error"]  # rad; (7.30) with an observer's speed
