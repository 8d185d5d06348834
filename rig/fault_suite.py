"""``rig faults``: every fault scenario over the whole chain, and what the host did about it.

CANopen scenarios run the section VII.B servo (``rig.demo.demo_config``) over
the emulated bus in lock-step with a fault injected at ``AT`` seconds; host
scenarios break the controller, a limit, Ctrl-C and SIGKILL; Modbus scenarios
make the emulated inverter time out or answer with an exception.

Each row: ``scenario``; ``detected_after_cycles`` (cycles from the injection to
the stop; null when nothing had to be stopped); ``drive_disabled`` (the drive's
final state produces no torque); ``samples_lost`` (cycles run minus rows in
samples.csv; for SIGKILL, the cycles the clock says ran minus the rows on disk);
``message`` (what the operator is told).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import signal
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from drivers.errors import CommunicationTimeout, ModbusExceptionResponse, RigError
from drivers.files import read_json
from rig.config import FaultsConfig, replace_axis
from rig.process import spawn_rig

__all__ = ["AT", "SCENARIOS", "run_faults"]

AT = 0.3  #: s: when the fault is injected
DURATION = 0.8  #: s: length of each CANopen run
NO_TORQUE = ("SWITCH ON DISABLED", "READY TO SWITCH ON", "SWITCHED ON", "FAULT", "FAULT REACTION ACTIVE")


def _last_t(run_dir: str) -> float:
    """The time [s] of the last complete row of ``samples.csv`` (0 when there is none)."""
    with (Path(run_dir) / "samples.csv").open() as f:
        lines = [line for line in f.read().splitlines()[1:] if line]
    for line in reversed(lines):
        with contextlib.suppress(ValueError):
            return float(line.split(",", 1)[0])
    return 0.0


def _rows(run_dir: str) -> int:
    with (Path(run_dir) / "samples.csv").open() as f:
        return sum(1 for _ in f) - 1


def _canopen(
    out: str,
    *,
    faults: dict[str, Any] | None = None,
    limits: dict[str, Any] | None = None,
    timed: bool = True,
) -> dict[str, Any]:
    from rig.demo import demo_config
    from rig.host.session import Session

    cfg = demo_config(out)
    cfg = dataclasses.replace(cfg, faults=dataclasses.replace(FaultsConfig(), **(faults or {})))
    cfg = replace_axis(cfg, "motor", limits=limits)
    with Session(cfg, emulate=True, duration=DURATION) as session:
        session.start()
        summary = session.run()
        drive = session.axes[0]
        state = "unknown"
        for _ in range(5):  # the SDO may be lost under frame loss
            try:
                state = drive.read_power_state().value  # type: ignore[attr-defined]
                break
            except RigError:
                continue
        period = session.period
    # the fault acts at the first SYNC at or after AT (SYNC k carries time (k + 1) T); frame loss acts
    # from the first cycle; a host fault and a limit act in the cycle they come in
    if faults and "frame_loss" in faults:
        injected = 0
    elif faults and any(k in faults for k in ("law_nan_at", "law_error_at", "interrupt_at")):
        injected = round(AT / period)
    elif timed:
        injected = math.ceil(AT / period - 1e-9) - 1
    else:
        injected = summary["cycles"]
    stopped = summary["safe_stop_reason"] is not None
    return {
        "detected_after_cycles": summary["cycles"] - injected if stopped else None,
        "drive_disabled": state in NO_TORQUE,
        "samples_lost": summary["cycles"] - _rows(summary["run_dir"]),
        "message": summary["safe_stop_reason"] or "completed without a stop",
    }


_KILL_CONFIG = """
[run]
time = "realtime"
period = 0.001
output = "{out}"
name = "sigkill"

[emulator]
preset = "dc-servo"

[emulator.params]
period = 0.001

[[axis]]
name = "motor"
kind = "cia402"
node_id = 1
mode = "voltage"
sync_rpdo = false

[axis.limits]
command = 48.0
speed = 300.0
watchdog_periods = 1000

[controller]
kind = "position-servo"
u0 = 48.0

[reference]
kind = "smooth-move"
distance = 10.0
duration = 1.0
"""


def _sigkill(out: str) -> dict[str, Any]:
    """``rig run`` in its own process, real time at 1 kHz, killed with SIGKILL after about 1 s."""
    config = Path(out) / "rt.toml"
    config.write_text(_KILL_CONFIG.format(out=Path(out) / "kill"))
    proc, _ = spawn_rig("run", "--config", str(config), "--emulate", "--duration", "5", quiet=True)
    started, marks = None, []
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and started is None:
        marks = list((Path(out) / "kill").glob("*/started.json"))
        if marks:
            with contextlib.suppress(ValueError, KeyError):
                started = float(read_json(marks[0], what="run's start")["wall_time"])
        time.sleep(0.01)
    time.sleep(1.0)
    killed_at = time.time()
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    if started is None:
        return {
            "detected_after_cycles": None,
            "drive_disabled": False,
            "samples_lost": None,
            "message": "the run did not start within 60 s",
        }
    ran = int((killed_at - started) / 0.001)
    # the time not on disk: from the last row's t (skipped real-time cycles count in t) to the kill
    lost = max(0, round((killed_at - started - _last_t(str(marks[0].parent))) / 0.001))
    return {
        "detected_after_cycles": None,
        "drive_disabled": False,  # the host is dead: only the drive's own supervision can stop it now
        "samples_lost": lost,
        "message": f"host killed after about {ran} cycles; {lost} samples ({lost} ms at 1 kHz) not on disk",
    }


def _modbus(mode: str) -> dict[str, Any]:
    """The Modbus inverter running at 50 rad/s, then every request times out or is answered with 04."""
    from drivers.modbus_inverter import ModbusInverterAxis
    from plant_emulator.modbus_inverter import InverterContext, InverterServer, default_model

    model = default_model("abb-drives-profile", comm_loss_timeout=0.3)
    context = InverterContext(model)
    context.timeout_sleep = 0.6
    message, cycles = "no error", None
    with InverterServer(model, dt=0.005, context=context) as server:
        drive = ModbusInverterAxis(
            "inverter", "abb-drives-profile", host="127.0.0.1", port=server.port, timeout=0.2
        )
        try:
            drive.setup()
            drive.enable(timeout=1.0)
            drive.command(50.0)
            context.fault_mode = mode
            for cycle in range(1, 20):
                try:
                    drive.feedback()
                except (CommunicationTimeout, ModbusExceptionResponse) as exc:
                    message, cycles = str(exc), cycle
                    try:
                        drive.quick_stop()  # the host's safe stop; on a dead line the drive's own trip must
                    except (CommunicationTimeout, ModbusExceptionResponse):
                        pass
                    break
            time.sleep(0.8)  # past the drive's communication-loss time
        finally:
            drive.close()
    return {
        "detected_after_cycles": cycles,
        "drive_disabled": not model.running,
        "samples_lost": 0,
        "message": message + (f"; drive tripped 0x{model.fault:04X}" if model.fault else ""),
    }


SCENARIOS: dict[str, Callable[[str], dict[str, Any]]] = {
    "frame-loss-1%": lambda out: _canopen(out, faults={"frame_loss": 0.01}),
    "frame-loss-10%": lambda out: _canopen(out, faults={"frame_loss": 0.10}),
    "tpdo-stall": lambda out: _canopen(out, faults={"tpdo_stall_at": AT}),
    "heartbeat-loss": lambda out: _canopen(
        out, faults={"heartbeat_loss_at": AT}, limits={"heartbeat_timeout": 0.15}
    ),
    "node-reset": lambda out: _canopen(out, faults={"node_reset_at": AT}),
    "over-current-emcy": lambda out: _canopen(out, faults={"overcurrent_at": AT}),
    "encoder-glitch": lambda out: _canopen(out, faults={"encoder_glitch_at": AT}),
    "controller-nan": lambda out: _canopen(out, faults={"law_nan_at": AT}),
    "limit-violation": lambda out: _canopen(out, limits={"speed": 5.0}, timed=False),
    "ctrl-c": lambda out: _canopen(out, faults={"interrupt_at": AT}),
    "modbus-timeout": lambda out: _modbus("timeout"),
    "modbus-exception": lambda out: _modbus("exception"),
    "sigkill-host": _sigkill,
}


def run_faults(names: list[str] | None = None) -> list[dict[str, Any]]:
    """Run the scenarios (all by default); one row each."""
    rows = []
    with tempfile.TemporaryDirectory() as out:
        for name in names or list(SCENARIOS):
            sub = Path(out) / name.replace("%", "pc")
            sub.mkdir()
            rows.append({"scenario": name, **SCENARIOS[name](str(sub))})
    return rows
