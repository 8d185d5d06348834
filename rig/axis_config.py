"""The ``[[axis]]`` tables of a rig configuration: one device each, its mode, units and limits.

``axis_config(path, n, table)`` checks one table (an unknown key, a wrong type or a value
out of range is a ``ConfigError`` naming the file, the axis and the key) and gives an
``AxisConfig``; ``rig.config`` reads the rest of the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from drivers.cia402_feedback import FEEDBACK_NAMES, feedback_problem
from drivers.errors import ConfigError
from rig.config_checks import check_axis_values, require_finite
from rig.params import typed_values

__all__ = ["ABORT_CONNECTION", "AXIS_KINDS", "AxisConfig", "AxisLimits", "AxisUnits", "axis_config"]

#: ``abort_connection`` names: the value of 0x6007 (None: the drive's own setting)
ABORT_CONNECTION = {"none": 0, "fault": 1, "disable-voltage": 2, "quick-stop": 3, "drive": None}

#: axis kinds and the modes each takes ("" : feedback only)
AXIS_KINDS = {
    "cia402": ("voltage", "cst", "csv", "csp", "pv", "dq-voltage"),
    "modbus": ("speed",),
    "cia406": ("",),
}


@dataclass(frozen=True)
class AxisUnits:
    """Unit factors for a device that does not report them (0: the device's own)."""

    counts_per_rev: int = 0  #: position increments per revolution
    rated_torque: float = 0.0  #: [N m]
    rated_current: float = 0.0  #: [A]
    position_unit: int = 0  #: SI unit code of positions (as 0x60A8), where the drive has no 0x60A8
    velocity_unit: int = 0  #: SI unit code of velocities (as 0x60A9), where the drive has no 0x60A9


@dataclass(frozen=True)
class AxisLimits:
    command: float = math.inf  #: |command| in the unit of the mode (csp: the travel from the start [rad])
    speed: float = math.inf  #: [rad/s]
    position_min: float = -math.inf  #: [rad]
    position_max: float = math.inf  #: [rad]
    current: float = math.inf  #: [A]
    watchdog_periods: int = 3  #: periods without a new sample before the stop (missed real-time cycles count)
    #: [s] in real time, the watchdog is at least this long (a PC's and a socket's jitter is not a period's)
    watchdog: float = 0.1
    heartbeat_timeout: float = 0.0  #: [s]; 0: not supervised
    #: a stop is confirmed when, after the disable, the speed stayed within rest_speed [rad/s]
    #: (or one speed unit of the axis, where that is coarser) for rest_time [s]
    rest_speed: float = 0.05
    rest_time: float = 0.1


@dataclass(frozen=True)
class AxisConfig:
    name: str
    kind: str
    node_id: int = 0  #: CANopen node id
    mode: str = ""
    profile: str = ""  #: command by this time profile instead of the law
    sync_rpdo: bool = True
    latency: float = 0.0  #: [s]
    enable_timeout: float = 1.0  #: [s]
    stop_timeout: float = 3.0  #: [s] for the drive's own stop ramp to end
    mode_timeout: float = 1.0  #: [s] for 0x6061 to show the mode written to 0x6060
    pdo: str = "remap"  #: cia402: "remap" (the host's mapping, within the device's) or "device" (its own)
    sdo_timeout: float = 0.0  #: [s] per SDO answer (0: the driver's default)
    sdo_retries: int = -1  #: SDO retries (-1: the driver's default)
    #: cia402: how the drive reacts when the host's heartbeat stops (0x6007): none, fault,
    #: disable-voltage, quick-stop, or "drive" (leave the drive's setting)
    abort_connection: str = "quick-stop"
    host_timeout: float = 0.0  #: [s] the drive's watch of the host's heartbeat (0: 3 heartbeats)
    #: cia402, the toolkit's drive: periods without a command RPDO before it stops itself (0: none);
    #: in real time at least rpdo_deadline [s] (a PC's cycle can come late by more than a period)
    rpdo_deadline_periods: int = 5
    rpdo_deadline: float = 0.02
    reset_fault: bool = False  #: cia402: a drive found in FAULT at enable is reset (else refused)
    eds: str = ""  #: the device's EDS/DCF ("" : the toolkit's)
    speed_from_position: bool = False  #: cia406: speed as the backward difference of the position
    #: cia402: what the drive's TPDOs carry beside its statusword: position (always), velocity, mode
    #: (0x6061), torque, current; without velocity the speed is the position's backward difference
    #: (a lean image for a fast loop: ["position"] is one TPDO of 6 bytes)
    feedback: tuple[str, ...] = FEEDBACK_NAMES
    map: str = ""  #: modbus register map
    unit: int = 1  #: modbus unit id
    host: str = ""  #: modbus TCP host
    port: int = 502  #: modbus TCP port
    serial: str = ""  #: modbus RTU serial device
    baudrate: int = 19200
    units: AxisUnits = field(default_factory=AxisUnits)
    limits: AxisLimits = field(default_factory=AxisLimits)


def _table(path: str, where: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: {where} must be a table")
    return value


def axis_config(path: str, n: int, table: Any) -> AxisConfig:
    """The checked ``[[axis]]`` table number ``n`` of file ``path``."""
    where = f"[[axis]] #{n + 1}"
    table = dict(_table(path, where, table))
    name = table.get("name")
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{path}: {where} needs a name (a string)")
    where = f"[[axis]] {name!r}"
    units = typed_values(AxisUnits, _table(path, where, table.pop("units", {})), f"{path}: {where} units")
    raw_limits = _table(path, where, table.pop("limits", {}))
    require_finite(f"{path}: {where} limits", raw_limits)
    limits = typed_values(AxisLimits, raw_limits, f"{path}: {where} limits")
    values = typed_values(AxisConfig, table, f"{path}: {where}", fixed=("units", "limits"))
    if "kind" not in values:
        raise ConfigError(f"{path}: {where} needs kind ({', '.join(AXIS_KINDS)})")
    axis = AxisConfig(**values, units=AxisUnits(**units), limits=AxisLimits(**limits))
    _check_axis(path, where, axis)
    return axis


def _check_axis(path: str, where: str, a: AxisConfig) -> None:
    if a.kind not in AXIS_KINDS:
        raise ConfigError(f"{path}: {where} kind = {a.kind!r}; known: {', '.join(AXIS_KINDS)}")
    if a.mode not in AXIS_KINDS[a.kind]:
        modes = ", ".join(m for m in AXIS_KINDS[a.kind] if m) or "none (a feedback-only axis)"
        raise ConfigError(f"{path}: {where} mode = {a.mode!r} for kind {a.kind}; expected {modes}")
    if a.kind in ("cia402", "cia406") and not 1 <= a.node_id <= 127:
        raise ConfigError(f"{path}: {where} node_id = {a.node_id}: must be 1..127")
    if a.kind == "modbus" and not a.map:
        raise ConfigError(f"{path}: {where} needs map (abb-drives-profile, delta-vfd-b)")
    if a.profile and not a.mode:
        raise ConfigError(f"{path}: {where} has a profile but no mode to command it in")
    if a.abort_connection not in ABORT_CONNECTION:
        raise ConfigError(
            f"{path}: {where} abort_connection = {a.abort_connection!r}; known: {', '.join(ABORT_CONNECTION)}"
        )
    if a.pdo not in ("remap", "device"):
        raise ConfigError(f"{path}: {where} pdo = {a.pdo!r}: remap or device")
    if set(a.feedback) != set(AxisConfig.feedback):
        if a.kind != "cia402" or a.mode == "dq-voltage":
            raise ConfigError(
                f"{path}: {where} feedback = {list(a.feedback)}: only a cia402 axis in a CiA 402 mode "
                "chooses what its TPDOs carry; remove the key"
            )
        problem = feedback_problem(a.feedback)
        if problem:
            raise ConfigError(f"{path}: {where} {problem}")
    check_axis_values(f"{path}: {where}", a)
