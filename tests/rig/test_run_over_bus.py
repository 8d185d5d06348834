"""System tests in lock-step: the whole chain over the emulated CAN bus, and every safety path."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import pathlib

import canopen
import numpy as np
import pytest

from drivers.cia402 import decode_state
from plant_emulator.presets import build_preset
from rig.config import load_config
from rig.emulate import preset_values
from rig.run import build_law, prepare

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def _cfg(tmp_path: pathlib.Path, **limits: float):  # type: ignore[no-untyped-def]
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path)))
    if limits:
        cfg = dataclasses.replace(cfg, limits=dataclasses.replace(cfg.limits, **limits))
    return cfg


def _samples(run_dir: str) -> np.ndarray:
    with open(pathlib.Path(run_dir) / "samples.csv") as f:
        rows = list(csv.reader(f))
    return np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))


def test_position_servo_over_the_bus_equals_the_pure_simulation(tmp_path: pathlib.Path) -> None:
    """Controller -> CiA 402 driver -> canopen -> emulated drive -> (3.4) -> TPDO -> controller,
    against the same law on the same axis with the same quantisation and timing, no bus."""
    cfg = _cfg(tmp_path)
    session = prepare(cfg, emulate=True, duration=2.0)
    summary = session.loop.run()
    session.close()
    assert summary["safe_stop_reason"] is None and summary["cycles"] == 5000
    wire = _samples(summary["run_dir"])

    devices, period = build_preset(
        "dc-servo", canopen.Network(), preset_values("dc-servo", cfg.emulator.params)
    )
    axis = devices[0].axis  # type: ignore[attr-defined]
    law, _, _ = build_law(cfg, period)
    cpr = 4096 / (2 * math.pi)
    pure = []
    for k in range(5000):
        if k:
            axis.advance(period, k * period)  # SYNC k+1 steps [t_k, t_k+1] (timestamps start at T)
        fb = (math.floor(axis.position * cpr) / cpr, round(axis.velocity * cpr) / cpr, 0.0, 0.0, 0x1237)
        u, _ref, y, _ = law(k * period, fb)
        pure.append((y, u))
        axis.set_command(-1, round(u * 1000) / 1000)  # mV on the wire, applied on receipt
    pure_a = np.array(pure)
    assert np.max(np.abs(wire[:, 2] - pure_a[:, 0])) < 1e-9
    assert np.max(np.abs(wire[:, 3] - pure_a[:, 1])) < 1e-9
    assert abs(wire[-1, 1] - wire[-1, 2]) < 0.01  # it does track: within 0.01 rad at the end


def _run_with(tmp_path: pathlib.Path, mutate, **limits: float) -> tuple[dict, object]:  # type: ignore[no-untyped-def]
    session = prepare(_cfg(tmp_path, **limits), emulate=True, duration=0.4)
    mutate(session)
    summary = session.loop.run()
    state = decode_state(session.loop.drive.sdo_read(0x6041))
    session.close()
    return summary, state


def _check_stopped(summary: dict, state: str, reason: str) -> None:  # type: ignore[type-arg]
    assert reason in summary["safe_stop_reason"]
    assert state == "SWITCH ON DISABLED"  # quick stop, then disabled
    run_dir = pathlib.Path(summary["run_dir"])
    assert len(_samples(str(run_dir))) == summary["cycles"]  # every sample up to the stop
    assert (
        json.loads((run_dir / "summary.json").read_text())["safe_stop_reason"] == summary["safe_stop_reason"]
    )
    assert (run_dir / "trace.asc").stat().st_size > 0 and (run_dir / "config.json").exists()


def test_speed_limit_stops_the_drive(tmp_path: pathlib.Path) -> None:
    summary, state = _run_with(tmp_path, lambda s: None, speed=5.0)
    _check_stopped(summary, state, "speed")
    assert 0 < summary["cycles"] < 1000


def test_nan_and_exception_from_the_controller(tmp_path: pathlib.Path) -> None:
    for bad, reason in ((math.nan, "controller output is nan"), (None, "ZeroDivisionError")):

        def mutate(session, bad=bad):  # type: ignore[no-untyped-def]
            law = session.loop.law

            def broken(t, fb):  # type: ignore[no-untyped-def]
                if t >= 0.1:
                    if bad is None:
                        return 1 / 0
                    return bad, 0.0, 0.0, (0.0, 0.0)
                return law(t, fb)

            session.loop.law = broken

        summary, state = _run_with(tmp_path, mutate)
        _check_stopped(summary, state, reason)
        assert summary["cycles"] == 250


def test_ctrl_c_stops_the_drive(tmp_path: pathlib.Path) -> None:
    def mutate(session):  # type: ignore[no-untyped-def]
        law = session.loop.law

        def interrupted(t, fb):  # type: ignore[no-untyped-def]
            if t >= 0.2:
                raise KeyboardInterrupt
            return law(t, fb)

        session.loop.law = interrupted

    summary, state = _run_with(tmp_path, mutate)
    _check_stopped(summary, state, "Ctrl-C")
    assert summary["cycles"] == 500


def test_tpdo_watchdog(tmp_path: pathlib.Path) -> None:
    def mutate(session):  # type: ignore[no-untyped-def]
        sync = session.loop.sync
        count = [0]

        def dying_sync() -> None:  # the device stops answering after 100 cycles
            count[0] += 1
            if count[0] <= 100:
                sync()

        session.loop.sync = dying_sync

    summary, state = _run_with(tmp_path, mutate)
    _check_stopped(summary, state, "no TPDO for 3 periods")
    assert summary["cycles"] == 102


def test_emcy_from_the_drive_stops_the_loop(tmp_path: pathlib.Path) -> None:
    def mutate(session):  # type: ignore[no-untyped-def]
        session.devices[0].write(0x6080, 0, 30)  # the drive trips over-speed at 30 rpm

    summary, state = _run_with(tmp_path, mutate)
    assert "EMCY 0x8400" in summary["safe_stop_reason"]
    # the drive is in its fault reaction (it brakes per SYNC, and the host stopped sending SYNC)
    # or in FAULT; the host's disable cannot leave either, which is correct
    assert state in ("FAULT REACTION ACTIVE", "FAULT")


def test_heartbeat_loss(tmp_path: pathlib.Path) -> None:
    def mutate(session):  # type: ignore[no-untyped-def]
        law = session.loop.law

        def silencing(t, fb):  # type: ignore[no-untyped-def]
            if abs(t - 0.15) < 1e-9:
                session.devices[0].write(0x1017, 0, 0)  # the drive's heartbeat stops
            return law(t, fb)

        session.loop.law = silencing

    summary, state = _run_with(tmp_path, mutate, heartbeat_timeout=0.15)
    _check_stopped(summary, state, "heartbeat lost")
    assert 600 <= summary["cycles"] <= 700


def test_config_errors_name_the_file_and_key(tmp_path: pathlib.Path) -> None:
    from drivers.errors import ConfigError

    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("sync_rpdo = false", "sync_rpdoo = false"))
    with pytest.raises(ConfigError, match=r"bad\.toml: unknown key 'sync_rpdoo' in \[drive\]"):
        load_config(bad)
    bad.write_text(EXAMPLE.read_text().replace("lam = -15.0", 'lam = "fast"'))
    with pytest.raises(ConfigError, match=r"\[controller\] lam"):
        load_config(bad)
    bad.write_text(EXAMPLE.read_text().replace("duration = 3.0", "duration = -1"))
    with pytest.raises(ConfigError, match=r"duration"):
        load_config(bad)
