"""System tests in lock-step: the whole chain over the emulated CAN bus, and every safety path."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import pathlib
from typing import Any

import canopen
import numpy as np
import pytest

from drivers.base import Feedback
from drivers.errors import ConfigError
from plant_emulator.presets import build_preset
from rig.config import load_config, replace_axis
from rig.host.references import reference_of
from rig.host.session import Session
from rig.laws import make_law

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def _cfg(tmp_path: pathlib.Path, faults: dict[str, Any] | None = None, **limits: float):  # type: ignore[no-untyped-def]
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path)))
    if faults:
        cfg = dataclasses.replace(cfg, faults=dataclasses.replace(cfg.faults, **faults))
    return replace_axis(cfg, "motor", limits=limits) if limits else cfg


def _samples(run_dir: str) -> np.ndarray:
    with open(pathlib.Path(run_dir) / "samples.csv") as f:
        rows = list(csv.reader(f))
    return np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))


def test_position_servo_over_the_bus_equals_the_pure_simulation(tmp_path: pathlib.Path) -> None:
    """Law -> CiA 402 driver -> canopen -> emulated drive -> (3.4) -> TPDO -> law, against the same
    law on the same axis with the same quantisation and timing, no bus."""
    cfg = _cfg(tmp_path)
    with Session(cfg, emulate=True, duration=2.0) as session:
        session.start()
        summary = session.run()
    assert summary["safe_stop_reason"] is None and summary["cycles"] == 5000
    wire = _samples(summary["run_dir"])

    devices, period = build_preset("dc-servo", canopen.Network(), cfg.emulator.physics)
    axis = devices[0].axis  # type: ignore[attr-defined]
    law = make_law(
        cfg.controller.kind, cfg.controller.params, period=period, reference=reference_of(cfg.reference)
    )
    cpr = 4096 / (2 * math.pi)
    pure = []
    for k in range(5000):
        if k:
            axis.advance(period, k * period)  # SYNC k+1 steps [t_k, t_k+1] (timestamps start at T)
        fb = Feedback(math.floor(axis.position * cpr) / cpr, round(axis.velocity * cpr) / cpr)
        out = law.step(k * period, [fb])
        pure.append((out.measurement, out.commands[0]))
        axis.set_command(-1, round(out.commands[0] * 1000) / 1000)  # mV on the wire, applied on receipt
    pure_a = np.array(pure)
    assert np.max(np.abs(wire[:, 2] - pure_a[:, 0])) < 1e-9
    assert np.max(np.abs(wire[:, 3] - pure_a[:, 1])) < 1e-9
    assert abs(wire[-1, 1] - wire[-1, 2]) < 0.01  # it does track: within 0.01 rad at the end


def _run(cfg: Any, mutate: Any = None) -> tuple[dict[str, Any], str]:
    with Session(cfg, emulate=True, duration=0.4) as session:
        if mutate is not None:
            mutate(session)
        session.start()
        summary = session.run()
        state = session.axes[0].read_power_state().value  # type: ignore[attr-defined]
    return summary, state


def _check_stopped(summary: dict[str, Any], state: str, reason: str) -> None:
    assert reason in summary["safe_stop_reason"]
    assert state == "SWITCH ON DISABLED"  # quick stop, then disabled
    run_dir = pathlib.Path(summary["run_dir"])
    assert len(_samples(str(run_dir))) == summary["cycles"]  # every sample up to the stop
    assert (
        json.loads((run_dir / "summary.json").read_text())["safe_stop_reason"] == summary["safe_stop_reason"]
    )
    assert (run_dir / "trace.asc").stat().st_size > 0 and (run_dir / "config.json").exists()


def test_speed_limit_stops_the_drive(tmp_path: pathlib.Path) -> None:
    summary, state = _run(_cfg(tmp_path, speed=5.0))
    _check_stopped(summary, state, "motor, node 1: speed")
    assert 0 < summary["cycles"] < 1000


@pytest.mark.parametrize(
    ("fault", "reason"),
    [("law_nan_at", "controller output is nan"), ("law_error_at", "InjectedFault: injected at 0.1 s")],
)
def test_nan_and_exception_from_the_law(tmp_path: pathlib.Path, fault: str, reason: str) -> None:
    summary, state = _run(_cfg(tmp_path, faults={fault: 0.1}))
    _check_stopped(summary, state, reason)
    assert summary["cycles"] == 250


def test_ctrl_c_stops_the_drive(tmp_path: pathlib.Path) -> None:
    summary, state = _run(_cfg(tmp_path, faults={"interrupt_at": 0.2}))
    _check_stopped(summary, state, "Ctrl-C")
    assert summary["cycles"] == 500


def test_tpdo_watchdog(tmp_path: pathlib.Path) -> None:
    summary, state = _run(_cfg(tmp_path, faults={"tpdo_stall_at": 0.04}))
    _check_stopped(summary, state, "no TPDO for 3 periods")
    assert summary["cycles"] == 101


def test_emcy_from_the_drive_stops_the_loop(tmp_path: pathlib.Path) -> None:
    def mutate(session: Session) -> None:
        session.transport.emulation.devices[0].write(0x6080, 0, 30)  # type: ignore[union-attr]  # trips at 30 rpm

    summary, state = _run(_cfg(tmp_path), mutate)
    assert "EMCY 0x8400" in summary["safe_stop_reason"]
    # the drive is in its fault reaction (it brakes per SYNC, and the host stopped sending SYNC)
    # or in FAULT; the host's disable cannot leave either, which is correct
    assert state in ("FAULT REACTION ACTIVE", "FAULT")


def test_heartbeat_loss(tmp_path: pathlib.Path) -> None:
    summary, state = _run(_cfg(tmp_path, faults={"heartbeat_loss_at": 0.15}, heartbeat_timeout=0.15))
    _check_stopped(summary, state, "heartbeat lost")
    assert 600 <= summary["cycles"] <= 750


def test_a_drive_that_leaves_operation_enabled_stops_the_run(tmp_path: pathlib.Path) -> None:
    """Someone else disables the drive (a controlword by SDO from another master): the statusword
    in the next TPDO says so, and the host stops instead of commanding a disabled drive."""

    def mutate(session: Session) -> None:
        drive = session.transport.emulation.devices[0]  # type: ignore[union-attr]
        hub = session.transport.emulation.bench.hub  # type: ignore[union-attr]

        def intruder(msg: Any) -> None:
            if msg.arbitration_id == 0x80 and abs(hub.clock - 0.1) < 1e-9:
                drive._apply_controlword(0x00)  # disable voltage, as an SDO from another master would

        hub.taps.append(intruder)

    summary, _ = _run(_cfg(tmp_path), mutate)
    assert "the drive left OPERATION ENABLED: SWITCH ON DISABLED" in summary["safe_stop_reason"]


def test_config_errors_name_the_file_and_key(tmp_path: pathlib.Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("sync_rpdo = false", "sync_rpdoo = false"))
    with pytest.raises(ConfigError, match=r"bad\.toml: \[\[axis\]\] 'motor': unknown parameter 'sync_rpdoo'"):
        load_config(bad)
    bad.write_text(EXAMPLE.read_text().replace("lam = -15.0", 'lam = "fast"'))
    with pytest.raises(ConfigError, match=r"\[controller\] position-servo: lam = 'fast': expected float"):
        load_config(bad)  # the law's parameters are checked with the file, not when the run is built
    bad.write_text(EXAMPLE.read_text().replace("duration = 3.0", "duration = -1"))
    with pytest.raises(ConfigError, match=r"duration"):
        load_config(bad)


def test_the_old_single_drive_form_gets_one_line_naming_the_new(tmp_path: pathlib.Path) -> None:
    old = tmp_path / "old.toml"
    old.write_text('[drive]\nnode_id = 1\nmode = "voltage"\n[controller]\nkind = "position-servo"\n')
    with pytest.raises(ConfigError) as exc:
        load_config(old)
    text = str(exc.value)
    assert (
        "\n" not in text and "old.toml: [drive] is the old single-drive form" in text and "[[axis]]" in text
    )


def test_a_safe_stop_brakes_on_the_drive_s_ramp_and_does_not_coast(tmp_path: pathlib.Path) -> None:
    """The host used to send disable right after quick stop, which cuts the drive's ramp (CiA 402
    transition 12): 100 rad/s at the stop, 100 rad/s a second later. Now it waits for the ramp."""
    cfg = load_config(EXAMPLE.with_name("dc_servo_speed_csv.toml"))
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path)))
    cfg = dataclasses.replace(cfg, faults=dataclasses.replace(cfg.faults, interrupt_at=0.5))
    with Session(cfg, emulate=True) as session:
        session.start()
        drive = session.transport.emulation.bench.devices[0]  # type: ignore[union-attr]
        summary = session.run()
        assert "Ctrl-C" in summary["safe_stop_reason"]
        assert summary["stop_confirmed"] is True
        assert abs(drive.axis.velocity) < 0.1  # type: ignore[attr-defined]
        assert session.axes[0].read_power_state().value == "SWITCH ON DISABLED"  # type: ignore[attr-defined]
        for _ in range(2500):  # one more second: nothing moves
            session.transport.emulation.bench.sync()  # type: ignore[union-attr]
        assert abs(drive.axis.velocity) < 0.1  # type: ignore[attr-defined]


def test_a_stop_that_cannot_be_confirmed_is_reported(tmp_path: pathlib.Path) -> None:
    """The bus is cut when the stop begins: the host cannot see the drive stop. The summary says
    so and ``rig run`` would exit 4, not 3."""
    from rig.cli.common import exit_code

    cfg = _cfg(tmp_path, faults={"interrupt_at": 0.1})
    cfg = replace_axis(cfg, "motor", stop_timeout=0.05, sdo_timeout=0.01)
    with Session(cfg, emulate=True, duration=0.4) as session:
        session.start()
        hub = session.transport.emulation.bench.hub  # type: ignore[union-attr]
        law = session.loop.law  # type: ignore[union-attr]
        step = law.step

        def cut_at_the_stop(t: float, samples: Any) -> Any:
            if t >= 0.1 - 1e-9:
                hub.drop = lambda m: True
            return step(t, samples)

        law.step = cut_at_the_stop  # type: ignore[method-assign]
        summary = session.run()
        hub.drop = None
    assert summary["stop_confirmed"] is False
    assert exit_code(summary) == 4 and exit_code({**summary, "stop_confirmed": True}) == 3
