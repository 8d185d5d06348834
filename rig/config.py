"""The rig configuration: a TOML file loaded into frozen dataclasses.

A rig is a set of named axes and one control law (SI units; see ``examples/``)::

    [run]        duration [s], time ("lockstep" | "realtime"), output (directory), name,
                 period [s] (default: the emulator preset's), trace ("asc" | "blf" | "none": the
                 CAN trace's format, trace.asc by default),
                 missed_sample ("hold" | "zero": a cycle without a new sample from a read axis),
                 answer_budget [s] (real time: the wait for the TPDOs answering a SYNC; 0: half
                 the period), late_stop (late cycles in a row that are a safe stop; 0: never),
                 rt_priority (SCHED_FIFO 1-99 of the real-time loop, 50; 0: none), rt_cpu (-1:
                 the last CPU, -2: not pinned), rt_lock_memory (true)
    [bus]        the CAN bus: interface, channel, bitrate, host, port (ignored with --emulate);
                 host_node (127), heartbeat [s] (0.1; 0: none): the host's heartbeat the drives watch;
                 sync ("host" | "external": another device sends SYNC; real time only)
    [emulator]   preset (dc-servo | im-drive | grid-converter | dyno) or device (a zoo drive's twin:
                 rig emulate --list, or a device profile file), and [emulator.params]
                 NAME = value (the preset's parameters); [emulator.inverter] NAME = value for
                 the emulated Modbus inverters (one per modbus axis)
    [[axis]]     name, kind (cia402 | modbus | cia406), and per kind:
                   cia402: node_id, mode (voltage | cst | csv | csp | pv | dq-voltage), sync_rpdo,
                           latency [s], enable_timeout [s], stop_timeout [s], mode_timeout [s],
                           pdo (remap | device), sdo_timeout [s], sdo_retries, abort_connection
                           (none | fault | disable-voltage | quick-stop | drive), host_timeout [s],
                           rpdo_deadline_periods, rpdo_deadline [s] (real time: max of
                           the two), reset_fault, feedback (what the TPDOs carry: position,
                           velocity, mode, torque, current), eds (default: the toolkit's)
                   cia406: node_id, speed_from_position, eds
                   modbus: map, unit, host + port (TCP) or serial + baudrate (RTU), mode = "speed"
                 profile = "TERM + ..." commands the axis by a time profile instead of the law
                 (plant_emulator.profiles: const, step, pulse, sine);
                 [axis.units] counts_per_rev, rated_torque [N m], rated_current [A],
                 position_unit, velocity_unit (SI unit codes): where the device does not report them;
                 [axis.limits] command, speed [rad/s], position_min/max [rad], current [A],
                 watchdog_periods (lock-step), watchdog [s] (real time: max of the two),
                 heartbeat_timeout [s] (0: off), rest_speed [rad/s] and rest_time [s] (a stop's rest)
    [controller] kind (see ``rig.laws.LAWS``), reads = [axis names], commands = [axis names],
                 the law's parameters, and design = "FILE" (a_m, b_m and lam from rig identify's
                 identification.json or rig design dtsm --json, the law's parameters from rig
                 tune --json; ``rig.identify.model_file``)
    [reference]  kind (smooth-move | step | constant | profile), distance, duration, start, value, profile
    [faults]     fault injection: on the emulated bus (--emulate): frame_loss, seed, tpdo_stall_at,
                 heartbeat_loss_at, node_reset_at, overcurrent_at, encoder_glitch_at [s],
                 encoder_glitch_counts; in the host: law_nan_at, law_error_at, interrupt_at [s]

An unknown section or key, or a value of the wrong type, is a ``ConfigError``
naming the file and the key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Literal

from drivers.errors import ConfigError
from drivers.files import read_toml
from rig.axis_config import ABORT_CONNECTION, AXIS_KINDS, AxisConfig, AxisLimits, AxisUnits, axis_config
from rig.config_checks import check_bus, check_faults, check_reference, check_run
from rig.identify.model_file import Model, read_model
from rig.params import typed_values

__all__ = [
    "ABORT_CONNECTION",
    "AXIS_KINDS",
    "AxisConfig",
    "AxisLimits",
    "AxisUnits",
    "BusConfig",
    "ControllerConfig",
    "EmulatorConfig",
    "FaultsConfig",
    "ReferenceConfig",
    "RigConfig",
    "RunConfig",
    "load_config",
    "replace_axis",
    "rig_config",
]


@dataclass(frozen=True)
class RunConfig:
    duration: float = 3.0  #: [s]
    time: Literal["lockstep", "realtime"] = "lockstep"
    output: str = "runs"
    name: str = "run"
    period: float = 0.0  #: [s]; 0: the emulator preset's period
    #: the CAN trace: trace.asc (Vector ASCII), trace.blf (Vector's binary logging format) or none
    trace: Literal["asc", "blf", "none"] = "asc"
    #: a cycle whose samples did not all come new (a TPDO missed): "hold" the law's last
    #: commands (nothing new is sent; the law is not stepped on stale feedback) or send "zero"
    missed_sample: Literal["hold", "zero"] = "hold"
    #: [s] real time with the host's SYNC: how long a cycle waits for the TPDOs answering its
    #: SYNC before it goes on with what it has (a late cycle); 0: half the period
    answer_budget: float = 0.0
    #: that many late cycles in a row are a safe stop (0: never)
    late_stop: int = 100
    #: real time (``rig.host.realtime``): SCHED_FIFO priority of the loop thread (the bus's
    #: receive thread one above; 0: normal scheduling), the CPU they are pinned to (-1: the last
    #: one; -2: not pinned), and memory locked; each asked for, what was granted in the summary
    rt_priority: int = 50
    rt_cpu: int = -1
    rt_lock_memory: bool = True


@dataclass(frozen=True)
class BusConfig:
    interface: str = "socketcand"
    channel: str = "can0"
    bitrate: int = 0
    host: str = "127.0.0.1"
    port: int = 29536
    host_node: int = 127  #: the host's node id: the id of its heartbeat
    heartbeat: float = 0.1  #: [s] the host's heartbeat period, which the drives watch (0: none)
    sync: str = "host"  #: who produces SYNC: the host, or "external" (another device; real time only)


@dataclass(frozen=True)
class EmulatorConfig:
    preset: str = ""  #: the CANopen preset ("" : none)
    device: str = ""  #: a drive's twin instead: a zoo profile's name or a profile file (.toml)
    params: dict[str, Any] = field(default_factory=dict)  #: the preset's parameters
    inverter: dict[str, Any] = field(default_factory=dict)  #: parameters of emulated Modbus inverters


@dataclass(frozen=True)
class ControllerConfig:
    kind: str
    reads: tuple[str, ...] = ()
    commands: tuple[str, ...] = ()
    params: dict[str, Any] = field(default_factory=dict)  #: the law's, typed by its Params
    design: Model | None = None  #: ``design = "FILE"``: the model its a_m, b_m (and lam) came from


@dataclass(frozen=True)
class ReferenceConfig:
    kind: Literal["smooth-move", "step", "constant", "profile"] = "smooth-move"
    distance: float = 10.0
    duration: float = 1.0  #: [s]
    start: float = 0.0  #: [s]
    value: float = 0.0
    profile: str = ""
    #: a position reference: "start" = from where the read axis stands at the first cycle; "zero" = absolute
    origin: Literal["start", "zero"] = "start"


@dataclass(frozen=True)
class FaultsConfig:
    """Fault injection: the emulator's (``plant_emulator.faults.FaultPlan``, --emulate only) and the
    host's (``rig.laws.injected``); times [s] of the run (inf: never)."""

    frame_loss: float = 0.0
    seed: int = 0
    tpdo_stall_at: float = math.inf
    heartbeat_loss_at: float = math.inf
    node_reset_at: float = math.inf
    overcurrent_at: float = math.inf
    encoder_glitch_at: float = math.inf
    encoder_glitch_counts: int = 2048
    law_nan_at: float = math.inf  #: host side: the law's commands become NaN
    law_error_at: float = math.inf  #: host side: the law raises an exception
    interrupt_at: float = math.inf  #: host side: Ctrl-C arrives


@dataclass(frozen=True)
class RigConfig:
    source: str
    run: RunConfig
    bus: BusConfig
    emulator: EmulatorConfig
    axes: tuple[AxisConfig, ...]
    controller: ControllerConfig
    reference: ReferenceConfig
    faults: FaultsConfig = field(default_factory=FaultsConfig)

    def axis(self, name: str) -> AxisConfig:
        for a in self.axes:
            if a.name == name:
                return a
        raise ConfigError(f"{self.source}: no [[axis]] named {name!r}")

    def as_dict(self) -> dict[str, Any]:
        """The resolved configuration, JSON-ready (inf as null)."""

        def clean(v: Any) -> Any:
            if isinstance(v, float) and not math.isfinite(v):
                return None
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, (list, tuple)):
                return [clean(x) for x in v]
            if hasattr(v, "__dataclass_fields__"):
                return {f.name: clean(getattr(v, f.name)) for f in fields(v)}
            return v

        return {"source": self.source, **{f.name: clean(getattr(self, f.name)) for f in fields(self)[1:]}}


_SECTIONS = {"run": RunConfig, "bus": BusConfig, "reference": ReferenceConfig, "faults": FaultsConfig}
_OLD_FORM = (
    "is the old single-drive form: describe each device as an [[axis]] table (name, kind, node_id, mode, "
    "[axis.limits]) and name the axes in [controller] reads and commands "
    "(see examples/dc_servo_position.toml)"
)


def _table(path: str, where: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: {where} must be a table")
    return value


def _controller(path: str, table: Any) -> ControllerConfig:
    table = dict(_table(path, "[controller]", table))
    kind = table.pop("kind", None)
    if not isinstance(kind, str):
        raise ConfigError(f"{path}: [controller] needs kind (a string naming the law)")
    roles: dict[str, tuple[str, ...]] = {}
    for key in ("reads", "commands"):
        value = table.pop(key, [])
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ConfigError(f"{path}: [controller] {key} = {value!r}: expected a list of axis names")
        roles[key] = tuple(value)
    model = None
    if "design" in table:
        model = _design(path, table, kind)
    return ControllerConfig(kind, roles["reads"], roles["commands"], table, model)


def _design(path: str, table: dict[str, Any], kind: str) -> Model:
    """``design = "FILE"`` (a path relative to the configuration's folder): its a_m, b_m and,
    from a design file, lam go into ``table`` (from a ``rig tune`` file, its params, for the
    kind it names); a key also given in ``table`` is an error."""
    design = table.pop("design")
    where = f"{path}: [controller] design = {design!r}"
    if not isinstance(design, str) or not design:
        raise ConfigError(
            f"{where}: expected the path of rig identify's identification.json (or its run "
            "directory) or of rig design dtsm --json's output"
        )
    file = Path(design) if Path(design).is_absolute() else Path(path).parent / design
    model = read_model(file, where=where)
    if model.law is not None and model.law != kind:
        raise ConfigError(f"{where}: designed for kind = {model.law!r}, not {kind!r} (rig tune {kind} ...)")
    given = (
        dict(model.params or {})
        if model.law is not None
        else {"a_m": model.a_m, "b_m": model.b_m, **({} if model.lam is None else {"lam": model.lam})}
    )
    both = sorted(set(given) & set(table))
    if both:
        raise ConfigError(f"{where}: {', '.join(both)} also given in [controller]: give each once")
    table.update(given)
    return model


def _emulator(path: str, table: Any) -> EmulatorConfig:
    table = dict(_table(path, "[emulator]", table))
    known = {"preset", "device", "params", "inverter"}
    unknown = set(table) - known
    if unknown:
        raise ConfigError(
            f"{path}: unknown key(s) {sorted(unknown)} in [emulator]; known: {', '.join(known)}"
        )
    preset, device = table.get("preset", ""), table.get("device", "")
    for key, value in (("preset", preset), ("device", device)):
        if not isinstance(value, str):
            raise ConfigError(f"{path}: [emulator] {key} = {value!r}: expected a string")
    if preset and device:
        raise ConfigError(f"{path}: [emulator] has both preset and device: give one")
    if device.endswith(".toml") and not Path(device).is_absolute():
        device = str(Path(path).parent / device)
    params = _table(path, "[emulator.params]", table.get("params", {}))
    inverter = _table(path, "[emulator.inverter]", table.get("inverter", {}))
    return EmulatorConfig(preset, device, dict(params), dict(inverter))


def rig_config(doc: dict[str, Any], source: str) -> RigConfig:
    """A checked configuration from a parsed TOML document; ``source`` names it in errors."""
    for old in ("drive", "limits"):
        if old in doc:
            raise ConfigError(f"{source}: [{old}] {_OLD_FORM}")
    known = {*_SECTIONS, "emulator", "axis", "controller"}
    for key in doc:
        if key not in known:
            raise ConfigError(f"{source}: unknown section [{key}]; known: {', '.join(sorted(known))}")
    sections = {
        name: cls(**typed_values(cls, _table(source, f"[{name}]", doc.get(name, {})), f"{source}: [{name}]"))
        for name, cls in _SECTIONS.items()
    }
    raw_axes = doc.get("axis", [])
    if not isinstance(raw_axes, list) or not raw_axes:
        raise ConfigError(f"{source}: describe at least one device as an [[axis]] table")
    axes = tuple(axis_config(source, n, t) for n, t in enumerate(raw_axes))
    if "controller" not in doc:
        raise ConfigError(f"{source}: [controller] is missing: name the law (kind) and its axes")
    cfg = RigConfig(
        source=source,
        emulator=_emulator(source, doc.get("emulator", {})),
        axes=axes,
        controller=_controller(source, doc["controller"]),
        **sections,
    )
    _check_rig(cfg)
    return _default_roles(cfg)


def _default_roles(cfg: RigConfig) -> RigConfig:
    """A law over one axis needs no names: with one commandable axis, it reads and commands that one."""
    c = cfg.controller
    commands, reads = c.commands, c.reads
    if not commands:
        commandable = [a.name for a in cfg.axes if a.mode and not a.profile]
        if len(commandable) != 1:
            raise ConfigError(
                f"{cfg.source}: [controller] commands is missing: name the axes the law commands "
                f"(of {', '.join(commandable) or 'none'})"
            )
        commands = (commandable[0],)
    reads = reads or commands
    return replace(cfg, controller=replace(c, reads=reads, commands=commands))


def _check_rig(cfg: RigConfig) -> None:
    src = cfg.source
    b = cfg.bus
    if b.sync not in ("host", "external"):
        raise ConfigError(f"{src}: [bus] sync = {b.sync!r}: host or external")
    if b.sync == "external" and cfg.run.time != "realtime":
        raise ConfigError(
            f'{src}: [bus] sync = "external" needs [run] time = "realtime" (lock-step is the host\'s SYNC)'
        )
    if not 1 <= b.host_node <= 127:
        raise ConfigError(f"{src}: [bus] host_node = {b.host_node}: must be 1..127")
    if b.host_node in [a.node_id for a in cfg.axes if a.kind != "modbus"]:
        raise ConfigError(f"{src}: [bus] host_node = {b.host_node} is also an axis's node_id")
    names = [a.name for a in cfg.axes]
    for name in names:
        if names.count(name) > 1:
            raise ConfigError(f"{src}: two [[axis]] tables are named {name!r}")
    nodes = [a.node_id for a in cfg.axes if a.kind != "modbus"]
    for node in nodes:
        if nodes.count(node) > 1:
            raise ConfigError(f"{src}: two CANopen axes have node_id {node}")
    c = cfg.controller
    for key in ("reads", "commands"):
        for name in getattr(c, key):
            if name not in names:
                raise ConfigError(
                    f"{src}: [controller] {key} names {name!r}; the axes are {', '.join(names)}"
                )
    for name in c.commands:
        a = cfg.axis(name)
        if not a.mode or a.profile:
            raise ConfigError(
                f"{src}: [controller] commands {name!r}, which has "
                + ("a profile" if a.profile else "no mode (a feedback-only axis)")
            )
    if c.design is not None:
        _check_design(cfg, c.design)
    check_run(src, cfg.run)
    check_bus(src, b)
    check_reference(src, cfg.reference)
    check_faults(f"{src}: [faults]", cfg.faults)


def _check_design(cfg: RigConfig, model: Model) -> None:
    """The model's input is what the commanded axes take (voltage mode, or CST for a torque); a
    design (it has lam) was made for the run's period."""
    where = f"{cfg.source}: [controller] design ({model.source})"
    mode = "cst" if model.input == "torque" else "voltage"
    for name in cfg.controller.commands:
        if cfg.axis(name).mode != mode:
            raise ConfigError(
                f"{where}: its input is a {model.input}, so axis {name!r} must be in mode = {mode!r}, "
                f"not {cfg.axis(name).mode!r}"
            )
    period = cfg.run.period
    designed = model.lam is not None or model.law is not None
    if designed and period > 0.0 and abs(model.dt - period) > 1e-9 * period:
        raise ConfigError(
            f"{where}: designed for T = {model.dt:g} s, but [run] period = {period:g} s: design it again "
            "with --dt"
        )


def replace_axis(
    cfg: RigConfig,
    name: str,
    *,
    limits: dict[str, Any] | None = None,
    units: dict[str, Any] | None = None,
    **changes: Any,
) -> RigConfig:
    """``cfg`` with the axis ``name`` changed (and its limits and units, by key)."""
    a = cfg.axis(name)
    if limits:
        changes["limits"] = replace(a.limits, **limits)
    if units:
        changes["units"] = replace(a.units, **units)
    axes = tuple(replace(x, **changes) if x.name == name else x for x in cfg.axes)
    return replace(cfg, axes=axes)


def load_config(path: str | Path) -> RigConfig:
    """Load and check a rig configuration file (``drivers.files.read_toml``: a regular file of at
    most ``CONFIG_LIMIT``, UTF-8, not nested deeper than ``MAX_DEPTH``)."""
    p = Path(path)
    return rig_config(read_toml(p, what="rig configuration"), str(p))
