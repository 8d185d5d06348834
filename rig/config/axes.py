"""The ``[[axis]]`` tables of a rig configuration: one device each, its mode, units and limits.

``axis_config(path, n, table)`` checks one table: its keys against the fields here
(``drivers.schema.key``: a key of another kind of axis is refused too), its mode against its
kind, its ``[axis.units]`` and ``[axis.limits]``; an error is a ``ConfigError`` naming the file,
the axis (by its name, or its number before it has one), the key and the value. ``rig.config``
reads the rest of the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from drivers.cia402_feedback import FEEDBACK_NAMES, feedback_problem
from drivers.errors import ConfigError
from drivers.maps.logical import MAX_AXES
from drivers.schema import Refused, key, key_of, keys
from rig.config import checks as fmt
from rig.config.params import typed_values

__all__ = ["ABORT_CONNECTION", "AXIS_KINDS", "AxisConfig", "AxisLimits", "AxisUnits", "axis_config"]

#: ``abort_connection`` names: the value of 0x6007 (None: the drive's own setting)
ABORT_CONNECTION = {"none": 0, "fault": 1, "disable-voltage": 2, "quick-stop": 3, "drive": None}

#: axis kinds and the modes each takes ("" : feedback only)
AXIS_KINDS = {
    "cia402": ("voltage", "cst", "csv", "csp", "ip", "pv", "dq-voltage"),
    "modbus": ("speed",),
    "cia406": ("",),
}
CANOPEN = ("cia402", "cia406")
_U32 = 0xFFFF_FFFF


@dataclass(frozen=True)
class AxisUnits:
    """Unit factors for a device that does not report them (0: the device's own)."""

    counts_per_rev: int = key(0, "increments/rev", "position increments per revolution", ge=0, le=fmt.INT32)
    rated_torque: float = key(0.0, "N m", "the rated torque (0x6076's)", ge=0.0)
    rated_current: float = key(0.0, "A", "the rated current (0x6075's)", ge=0.0)
    position_unit: int = key(
        0, "", "SI unit code of positions (as 0x60A8), where the drive has no 0x60A8", ge=0, le=_U32
    )
    velocity_unit: int = key(
        0, "", "SI unit code of velocities (as 0x60A9), where the drive has no 0x60A9", ge=0, le=_U32
    )


def _limit(unit: str, doc: str) -> Any:
    return key(math.inf, unit, doc, gt=0.0)


@dataclass(frozen=True)
class AxisLimits:
    """What the host holds the axis to (a limit left out: none); and how a stop is confirmed.

    Raises
    ------
    Refused
        If position_min is not below position_max.
    """

    command: float = _limit("", "|command| in the unit of the mode (csp: the travel from the start [rad])")
    speed: float = _limit("rad/s", "|speed|")
    position_min: float = key(-math.inf, "rad", "the lowest position")
    position_max: float = key(math.inf, "rad", "the highest position; above position_min")
    current: float = _limit("A", "|current|")
    watchdog_periods: int = key(
        3, "periods", "periods without a new sample before the stop (missed real-time cycles count)", ge=1
    )
    watchdog: float = key(
        0.1,
        "s",
        "in real time the watchdog is at least this long (a PC's and a socket's jitter is not a period's)",
        ge=0.0,
    )
    heartbeat_timeout: float = key(
        0.0,
        "s",
        "the drive's heartbeat the host watches (the drive's 0x1017 is set to a third of it)",
        ge=0.0,
        le=3 * fmt.MAX_HEARTBEAT,
        also={0.0: "not supervised"},
    )
    rest_speed: float = key(
        0.05,
        "rad/s",
        "a stop is confirmed when, after the disable, the speed stayed within this (or one speed unit "
        "of the axis, where that is coarser) for rest_time",
        gt=0.0,
    )
    rest_time: float = key(0.1, "s", "see rest_speed", ge=0.0, le=60.0)

    def __post_init__(self) -> None:
        if not self.position_min < self.position_max:
            raise Refused(
                "position_min",
                self.position_min,
                f"must be < position_max = {self.position_max!r}: no position is allowed",
            )


@dataclass(frozen=True)
class AxisConfig:
    """One device: a CiA 402 drive, a CiA 406 encoder or a Modbus inverter (the keys of other
    kinds are refused); ``[axis.units]`` and ``[axis.limits]`` are its sub-tables."""

    name: str = key(doc="the axis's name, as [controller] reads and commands name it")
    kind: Literal["cia402", "modbus", "cia406"] = key(doc="the device's profile")
    node_id: int = key(0, "", "CANopen node id", ge=1, le=127, kinds=CANOPEN)
    axis: int = key(
        1,
        "",
        "which axis of a drive of several on one node (CiA 402: axis n's objects 0x800 (n - 1) above "
        "axis 1's, 0x6840, 0x6841, ...)",
        ge=1,
        le=MAX_AXES,
        kinds=("cia402",),
    )
    mode: str = key(
        "",
        "",
        "the mode it is commanded in: cia402 voltage, cst, csv, csp, ip, pv, dq-voltage; modbus speed; "
        'cia406 none ("": feedback only)',
    )
    profile: str = key(
        "",
        "",
        "commands the axis by this time profile instead of the law (drivers.profiles)",
        check=fmt.profile,
    )
    sync_rpdo: bool = key(
        True, "", "the command RPDO is applied at the next SYNC (else on receipt)", kinds=("cia402",)
    )
    latency: float = key(
        0.0, "s", "the drive's command latency 0x2001", ge=0.0, le=fmt.MAX_LATENCY, kinds=("cia402",)
    )
    enable_timeout: float = key(
        1.0, "s", "for the drive to reach OPERATION ENABLED", ge=0.0, kinds=("cia402",)
    )
    stop_timeout: float = key(3.0, "s", "for the drive's own stop ramp to end", ge=0.0, kinds=("cia402",))
    mode_timeout: float = key(
        1.0, "s", "for 0x6061 to show the mode written to 0x6060", ge=0.0, kinds=("cia402",)
    )
    pdo: Literal["remap", "device"] = key(
        "remap", "", "remap: the host's mapping, within the device's; device: its own", kinds=("cia402",)
    )
    sdo_timeout: float = key(0.0, "s", "per SDO answer", ge=0.0, also={0.0: "the driver's"}, kinds=CANOPEN)
    sdo_retries: int = key(-1, "", "SDO retries", ge=0, also={-1: "the driver's"}, kinds=CANOPEN)
    abort_connection: Literal["none", "fault", "disable-voltage", "quick-stop", "drive"] = key(
        "quick-stop",
        "",
        "how the drive reacts when the host's heartbeat stops (0x6007); drive: leave its setting",
        kinds=("cia402",),
    )
    host_timeout: float = key(
        0.0,
        "s",
        "the drive's watch of the host's heartbeat",
        ge=0.0,
        le=fmt.MAX_HEARTBEAT,
        also={0.0: "3 heartbeats"},
        kinds=("cia402",),
    )
    rpdo_deadline_periods: int = key(
        5,
        "periods",
        "the toolkit's drive: periods without a command RPDO before it stops itself",
        ge=0,
        le=1000,
        also={0: "none"},
        kinds=("cia402",),
    )
    rpdo_deadline: float = key(
        0.02,
        "s",
        "in real time the RPDO deadline is at least this (a PC's cycle can come late by more than a period)",
        ge=0.0,
        le=60.0,
        kinds=("cia402",),
    )
    reset_fault: bool = key(
        False, "", "a drive found in FAULT at enable is reset (else refused)", kinds=("cia402",)
    )
    eds: str = key(
        "",
        "",
        "the device's EDS/DCF, a path relative to this file's folder (\"\": the toolkit's)",
        kinds=CANOPEN,
    )
    speed_from_position: bool = key(
        False, "", "the speed as the backward difference of the position", kinds=("cia406",)
    )
    feedback: tuple[str, ...] = key(
        FEEDBACK_NAMES,
        "",
        "what the drive's TPDOs carry beside its statusword: position (always), velocity, mode "
        "(0x6061), torque, current; without velocity the speed is the position's backward difference "
        '(a lean image for a fast loop: ["position"] is one TPDO of 6 bytes); not in mode dq-voltage',
        rule=f"position and any of {', '.join(FEEDBACK_NAMES[1:])}",
        kinds=("cia402",),
    )
    map: str = key(
        "",
        "",
        "the register map (abb-drives-profile, delta-vfd-b)",
        check=fmt.register_map,
        kinds=("modbus",),
    )
    unit: int = key(1, "", "the Modbus unit id", ge=0, le=247, kinds=("modbus",))
    host: str = key("", "", "Modbus TCP: the inverter's address", kinds=("modbus",))
    port: int = key(502, "", "Modbus TCP: the port", ge=1, le=65535, kinds=("modbus",))
    serial: str = key("", "", "Modbus RTU: the serial device", kinds=("modbus",))
    baudrate: int = key(19200, "bit/s", "Modbus RTU: the baud rate", gt=0, kinds=("modbus",))
    units: AxisUnits = field(default_factory=AxisUnits)  #: ``[axis.units]``
    limits: AxisLimits = field(default_factory=AxisLimits)  #: ``[axis.limits]``


def _table(path: str, where: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: {where} must be a table")
    return value


def axis_config(path: str, n: int, table: Any) -> AxisConfig:
    """The checked ``[[axis]]`` table number ``n`` of file ``path``.

    Parameters
    ----------
    path : str
        The file, named in errors.
    n : int
        The table's number, from 1.
    table : Any
        The ``[[axis]]`` table.

    Returns
    -------
    AxisConfig
        The axis.

    Raises
    ------
    ConfigError
        If a key is unknown, of a wrong type or refused (file, axis and key named).
    """
    where = f"[[axis]] #{n + 1}"
    table = dict(_table(path, where, table))
    name = table.get("name")
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{path}: {where} needs a name (a string)")
    where = f"{path}: [[axis]] {name!r}"
    units = typed_values(AxisUnits, _table(path, where, table.pop("units", {})), f"{where} units")
    limits = typed_values(AxisLimits, _table(path, where, table.pop("limits", {})), f"{where} limits")
    values = typed_values(AxisConfig, table, where)
    if values.get("eds") and not Path(values["eds"]).is_absolute():  # as design and [emulator] device
        values["eds"] = str(Path(path).parent / values["eds"])
    if "kind" not in values:
        raise ConfigError(f"{where} needs kind ({', '.join(AXIS_KINDS)})")
    _check_kind(where, values)
    try:
        return AxisConfig(**values, units=AxisUnits(**units), limits=AxisLimits(**limits))
    except Refused as exc:
        raise ConfigError(f"{where} limits {exc}") from None


def _check_kind(where: str, values: dict[str, Any]) -> None:
    """The keys and the mode of the axis's kind, and what that kind needs."""
    kind = values["kind"]
    fields = keys(AxisConfig)
    for name, value in values.items():
        spec = key_of(fields[name])
        if spec is not None and spec.kinds and kind not in spec.kinds:
            shown = list(value) if isinstance(value, tuple) else value  # as the file wrote it
            raise ConfigError(
                f"{where} {name} = {shown!r}: a key of {' and '.join(spec.kinds)} axes, not of "
                f"kind {kind}: leave it out"
            )
    mode = values.get("mode", "")
    if mode not in AXIS_KINDS[kind]:
        modes = ", ".join(m for m in AXIS_KINDS[kind] if m) or "none (a feedback-only axis)"
        raise ConfigError(f"{where} mode = {mode!r} for kind {kind}; expected {modes}")
    if kind in CANOPEN and "node_id" not in values:
        raise ConfigError(f"{where} node_id = 0: must be 1..127")
    if kind == "modbus" and not values.get("map"):
        raise ConfigError(f"{where} needs map (abb-drives-profile, delta-vfd-b)")
    if values.get("serial") and values.get("unit", 1) == 0:
        raise ConfigError(f"{where} unit = 0: must be 1 .. 247 on an RTU line (0 is its broadcast)")
    if set(values.get("feedback", FEEDBACK_NAMES)) != set(FEEDBACK_NAMES):
        if mode == "dq-voltage":
            raise ConfigError(
                f"{where} feedback = {list(values['feedback'])}: only a cia402 axis in a CiA 402 mode "
                "chooses what its TPDOs carry; remove the key"
            )
        problem = feedback_problem(values["feedback"])
        if problem:
            raise ConfigError(f"{where} {problem}")
    if values.get("profile") and not mode:
        raise ConfigError(f"{where} has a profile but no mode to command it in")
    if values.get("eds"):
        from drivers.maps.cia402_needs import needed, require
        from drivers.maps.logical import axis_dictionary
        from drivers.maps.mode_names import mode_code
        from drivers.maps.od import load_od  # canopen: only where an axis names its own EDS

        try:
            od = load_od(values["eds"], values["node_id"])
            od = axis_dictionary(od, values.get("axis", 1), source=str(values["eds"]))  # it has the axis
            if kind == "cia402":  # and what its mode needs of it
                needs = needed(mode_code(mode), manufacturer=False)  # the drive is not identified yet
                require(od, needs, source=str(values["eds"]), what=f"mode {mode}")
        except ConfigError as exc:
            raise ConfigError(f"{where} eds: {exc}") from None
