"""``rig faults``: every fault scenario over the whole chain, and what the host did about it.

CANopen scenarios run the section VII.B servo (``rig.papers.demo.demo_config``) over
the emulated bus in lock-step with a fault injected at ``AT`` seconds; host
scenarios break the controller, a limit and Ctrl-C; Modbus scenarios make the
emulated inverter time out or answer with an exception. The cross-process
scenarios (``rig.faults.wire``: emulator and host in processes of their own, real
time over socketcand) kill, freeze and cut them, fill the disk and add a client
that never reads.

Each row: ``scenario``; ``detected_after_cycles`` (cycles from the injection to
the stop; null when nothing had to be stopped); ``drive_disabled`` (the drive's
final state produces no torque); ``samples_lost`` (cycles run minus rows in
samples.csv); ``message`` (what the operator is told); ``motor_speed_after_1s``
(rad/s, the emulated drive's 1 s after the injection); ``stop_confirmed`` (the
host saw every axis at rest and disabled by its stop).
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from drivers.errors import CommunicationTimeout, ModbusExceptionResponse, RigError
from drivers.maps.cia import PowerState
from plant_emulator.cia402_drive import EmulatedDrive
from rig.config import FaultsConfig, replace_axis
from rig.faults.wire import AFTER, WIRE_SCENARIOS, rows_on_disk

__all__ = ["AT", "LOCKSTEP", "SCENARIOS", "run_faults"]

AT = 0.3  #: s: when the fault is injected
DURATION = 0.8  #: s: length of each CANopen run
MODBUS_PERIOD = 0.01  #: [s] the Modbus host's cycle (the inverter's clock steps this much per cycle)
MODBUS_SPEED = 30.0  #: [rad/s] the inverter's speed when the fault comes
MODBUS_RAMP = 0.5  #: [s] of polling before the fault: the ramp (100 rad/s^2) and its settling


def _canopen(
    out: str,
    *,
    faults: dict[str, Any] | None = None,
    limits: dict[str, Any] | None = None,
    timed: bool = True,
) -> dict[str, Any]:
    from rig.host.session import Session
    from rig.papers.demo import demo_config

    cfg = demo_config(out)
    cfg = dataclasses.replace(cfg, faults=dataclasses.replace(FaultsConfig(), **(faults or {})))
    cfg = replace_axis(cfg, "motor", limits=limits)
    with Session(cfg, emulate=True, duration=DURATION) as session:
        session.start()
        summary = session.run()
        assert session.transport.emulation is not None and session.transport.emulation.bench is not None
        bench = session.transport.emulation.bench
        while bench.syncs * bench.period < AT + AFTER - 1e-9:  # the emulated world goes on to AT + 1 s
            bench.sync()
        emulated = bench.devices[0]
        assert isinstance(emulated, EmulatedDrive)
        speed = emulated.axis.velocity
        drive = session.axes[0]
        state = "unknown"
        for _ in range(5):  # the SDO may be lost under frame loss
            try:
                state = drive.read_power_state().value  # type: ignore[attr-defined]
                break
            except RigError:
                continue
        period = session.timebase.period
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
        "drive_disabled": state != "unknown" and PowerState(state).torque_off,
        "samples_lost": summary["cycles"] - rows_on_disk(Path(summary["run_dir"])),
        "message": summary["safe_stop_reason"] or "completed without a stop",
        "motor_speed_after_1s": round(speed, 3),
        "stop_confirmed": bool(summary["stop_confirmed"]),
    }


def _modbus(mode: str) -> dict[str, Any]:
    """The Modbus inverter turning at ``MODBUS_SPEED``, then every request times out or is answered
    with 04. In lock-step: the inverter's clock is stepped one ``MODBUS_PERIOD`` per host cycle
    (its physics and its communication-loss trip), so the outcome does not depend on the load;
    only the client's own timeout (0.2 s) runs on the wall clock, against a server that holds a
    swallowed request until it is stopped."""
    from drivers.modbus_inverter import ModbusInverterAxis
    from plant_emulator.modbus_inverter import InverterContext, InverterServer, default_model

    model = default_model("abb-drives-profile", comm_loss_timeout=0.3)
    context = InverterContext(model)
    context.timeout_sleep = 60.0  # no answer before the server stops
    message, cycles = "no error", None
    with InverterServer(model, context=context) as server:  # dt=None: lock-step
        drive = ModbusInverterAxis(
            "inverter", "abb-drives-profile", host="127.0.0.1", port=server.port, timeout=0.2
        )
        try:
            drive.setup()
            drive.enable(timeout=1.0)
            drive.command(MODBUS_SPEED)
            while model.t < MODBUS_RAMP:  # polled every cycle, as a host does
                model.step(MODBUS_PERIOD)
                drive.feedback()
            context.fault_mode = mode
            injected = model.t
            for cycle in range(1, 20):
                model.step(MODBUS_PERIOD)
                try:
                    drive.feedback()
                except (CommunicationTimeout, ModbusExceptionResponse) as exc:
                    message, cycles = str(exc), cycle
                    try:
                        drive.quick_stop()  # the host's safe stop; on a dead line the drive's own trip must
                    except (CommunicationTimeout, ModbusExceptionResponse):
                        pass
                    break
            while model.t < injected + AFTER - 1e-9:  # past the drive's communication-loss time
                model.step(MODBUS_PERIOD)
            speed = model.speed
        finally:
            drive.close()
    return {
        "detected_after_cycles": cycles,
        "drive_disabled": not model.running,
        "samples_lost": 0,
        "message": message + (f"; drive tripped 0x{model.fault:04X}" if model.fault else ""),
        "motor_speed_after_1s": round(speed, 3),
        "stop_confirmed": False,  # no answer: the host cannot confirm; the drive's own trip stops it
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
}
#: the scenarios in one process, lock-step (deterministic): the default test run's
LOCKSTEP = list(SCENARIOS)
SCENARIOS.update(WIRE_SCENARIOS)


def run_faults(
    names: list[str] | None = None, *, progress: Callable[[int, int], None] | None = None
) -> list[dict[str, Any]]:
    """Run the scenarios (all by default); one row each; ``progress(done, total)`` after each.

    Parameters
    ----------
    names : list[str] | None, optional
        The scenarios (None: all).
    progress : Callable[[int, int], None] | None, optional
        ``progress(done, total)``.

    Returns
    -------
    list[dict[str, Any]]
        One row each.
    """
    rows = []
    names = names or list(SCENARIOS)
    with tempfile.TemporaryDirectory() as out:
        for name in names:
            sub = Path(out) / name.replace("%", "pc")
            sub.mkdir()
            rows.append({"scenario": name, **SCENARIOS[name](str(sub))})
            if progress is not None:
                progress(len(rows), len(names))
    return rows
