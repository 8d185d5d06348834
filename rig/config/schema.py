"""The rig configuration: one TOML file, checked once when it is loaded, into frozen dataclasses.

A rig is a set of named axes and one control law (SI units; see ``examples/``): the tables
``[run]``, ``[bus]``, ``[emulator]`` (with ``[emulator.params]``, the preset's or the device's
parameters, and ``[emulator.inverter]``, the emulated Modbus inverters'), ``[[axis]]`` (with
``[axis.units]`` and ``[axis.limits]``, ``rig.config.axes``), ``[controller]`` (the law's
``kind``, the axes it ``reads`` and ``commands``, its parameters, ``rig.config.controller``),
``[reference]`` and ``[faults]``. Each table is a dataclass here; each key a field declared
with ``drivers.schema.key``: its type, default, unit, meaning and the values it allows are
data, which the loader checks and ``docs/configuration.md`` prints.

``rig.config.load``'s ``load_config(path)`` (or ``rig_config(doc, source)``) checks every key of
every table, the law's and the preset's parameters and the rules between tables
(``rig.config.rules``) in one pass; a ``RigConfig`` is valid, and what builds a run from it
(``rig.host.session``) checks nothing again. An unknown table or key, a value of the wrong type or
out of range is a ``ConfigError`` naming the file, the table (an axis by its name), the key and the
value, and saying what is allowed. Command-line overrides (``rig run --fault``, ``--duration``) are
``Override`` objects checked in the same pass, named by their option.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from typing import Any, Literal

from drivers.errors import ConfigError
from drivers.schema import MAX_PERIOD, MIN_PERIOD, key
from rig.config import checks as fmt
from rig.config.axes import ABORT_CONNECTION, AXIS_KINDS, AxisConfig, AxisLimits, AxisUnits
from rig.config.model import Model

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
    "Override",
    "ReferenceConfig",
    "RigConfig",
    "RunConfig",
    "replace_axis",
]


@dataclass(frozen=True)
class RunConfig:
    """How long, on which clock, where the run directory goes, and the real-time loop's requests."""

    duration: float = key(3.0, "s", "the run's length", gt=0.0)
    time: Literal["lockstep", "realtime"] = key(
        "lockstep", "", "lockstep: the host's SYNC paces emulated time; realtime: the wall clock does"
    )
    output: str = key("runs", "", "the folder the run directory goes to", check=fmt.output_path)
    name: str = key("run", "", "the run directory is <output>/<name>-<date>-<time>", check=fmt.run_name)
    period: float = key(
        0.0,
        "s",
        "the cycle period",
        ge=MIN_PERIOD,
        le=MAX_PERIOD,
        also={0.0: "the emulator preset's"},
        rule=f"{fmt.PERIOD_RULE} (0: the emulator preset's)",
    )
    trace: Literal["asc", "blf", "none"] = key(
        "asc",
        "",
        "the CAN trace: trace.asc (Vector ASCII), trace.blf (Vector's binary logging format) or none",
    )
    missed_sample: Literal["hold", "zero"] = key(
        "hold",
        "",
        "a cycle whose samples did not all come new (a TPDO missed): hold the law's last commands "
        "(nothing new is sent; the law is not stepped on stale feedback) or send zero",
    )
    answer_budget: float = key(
        0.0,
        "s",
        "real time with the host's SYNC: how long a cycle waits for the TPDOs answering its SYNC "
        "before it goes on with what it has (a late cycle); shorter than the period",
        ge=0.0,
        also={0.0: "half the period"},
    )
    late_stop: int = key(
        100, "cycles", "that many late cycles in a row are a safe stop", ge=0, also={0: "never"}
    )
    rt_priority: int = key(
        50,
        "",
        "real time: SCHED_FIFO priority of the loop thread (the bus's receive thread one above)",
        ge=0,
        le=99,
        also={0: "normal scheduling"},
    )
    rt_cpu: int = key(
        -1,
        "",
        "real time: the CPU the loop and receive threads are pinned to",
        ge=0,
        also={-1: "the last CPU", -2: "not pinned"},
    )
    rt_lock_memory: bool = key(True, "", "real time: lock the process's memory (mlockall)")
    rt_cpu_latency: int = key(
        0,
        "us",
        "real time: the PM QoS CPU latency held for the run (/dev/cpu_dma_latency): the CPUs stay out "
        "of idle states slower to leave than this",
        ge=0,
        le=2_000_000_000,
        also={-1: "none asked (the CPUs may sleep between periods)"},
    )


@dataclass(frozen=True)
class BusConfig:
    """The CAN bus of a run on hardware (without ``--emulate``): a python-can bus."""

    interface: str = key("socketcand", "", "the python-can interface", check=fmt.interface)
    channel: str = key("can0", "", "the python-can channel")
    bitrate: int = key(
        0, "bit/s", "the bit rate, where the interface sets it", ge=0, also={0: "the interface's"}
    )
    host: str = key("127.0.0.1", "", "socketcand: the server's address")
    port: int = key(29536, "", "socketcand: the server's TCP port", ge=1, le=65535)
    host_node: int = key(127, "", "the host's node id: the id of its heartbeat", ge=1, le=127)
    heartbeat: float = key(
        0.1,
        "s",
        "the host's heartbeat period, which the drives watch",
        ge=0.0,
        le=fmt.MAX_HEARTBEAT,
        also={0.0: "none"},
    )
    sync: Literal["host", "external"] = key(
        "host", "", "who produces SYNC: the host, or another device (real time only)"
    )


@dataclass(frozen=True)
class EmulatorConfig:
    """The emulated world of ``--emulate``: a physics preset's devices, or a drive's twin, and the
    emulated Modbus inverters. ``[emulator.params]`` are the preset's (or the twin's physics')
    parameters, ``[emulator.inverter]`` the inverters'; both tables are printed per preset below."""

    preset: str = key("", "", 'the CANopen preset: dc-servo, im-drive, grid-converter or dyno ("": none)')
    device: str = key(
        "", "", "a drive's twin instead: a zoo profile's name (rig emulate --list) or a profile file (.toml)"
    )
    params: dict[str, Any] = field(default_factory=dict)  #: the preset's parameters given, typed
    inverter: dict[str, Any] = field(default_factory=dict)  #: the inverters' parameters given, typed

    @cached_property
    def profile(self) -> Any:
        """The twin's ``DeviceProfile`` (None: a preset); ``rig.config.emulator`` read it at load."""
        from plant_emulator.device_profile import device_profile

        return device_profile(self.device) if self.device else None

    @cached_property
    def physics(self) -> Any:
        """The preset's parameters built (its dataclass; a twin's over its profile's), None without a
        preset; ``rig.config.emulator`` built and checked them at load (a copy made by
        ``dataclasses.replace`` builds its own)."""
        if not (self.preset or self.device):
            return None
        from plant_emulator.presets import PRESETS

        profile = self.profile
        name = profile.physics if profile else self.preset
        return PRESETS[name](**{**(profile.params if profile else {}), **self.params})


@dataclass(frozen=True)
class ControllerConfig:
    """The control law: its ``kind`` (``rig.laws.LAWS``), the axes it reads and commands, its
    parameters (below, per kind) and a design file they may come from."""

    kind: str = key(doc="the law (see the laws' parameters below)")
    reads: tuple[str, ...] = key((), "", "the axes the law reads, in its order (default: commands)")
    commands: tuple[str, ...] = key(
        (), "", "the axes the law commands, in its order (default: the one axis with a mode)"
    )
    params: dict[str, Any] = field(default_factory=dict)  #: the law's parameters given, typed by its Params
    design: Model | None = key(  # noqa: RUF009 - key() is a dataclasses.field
        None,
        "",
        "a file the law's a_m, b_m (and lam, or a rig tune design's parameters) come from: rig identify's "
        "identification.json (or its run directory), rig design dtsm --json's or rig tune --json's "
        "output; a path relative to this file's folder; a key it gives may not be given here too",
    )


@dataclass(frozen=True)
class ReferenceConfig:
    """The reference of the controlled variable (a position [rad], a speed [rad/s], a current [A])."""

    kind: Literal["smooth-move", "step", "constant", "profile"] = key(
        "smooth-move", "", "smooth-move: a quintic move by distance in duration from start"
    )
    distance: float = key(10.0, "", "smooth-move: the move, in the unit of the controlled variable")
    duration: float = key(1.0, "s", "smooth-move: the move's duration", gt=0.0)
    start: float = key(0.0, "s", "smooth-move and step: when it starts")
    value: float = key(0.0, "", "step and constant: the value")
    profile: str = key("", "", "profile: a time profile (drivers.profiles)", check=fmt.profile)
    origin: Literal["start", "zero"] = key(
        "start",
        "",
        "a position reference: from where the read axis stands at the first cycle (start) or absolute (zero)",
    )


def _at(doc: str) -> Any:
    return key(math.inf, "s", doc, ge=0.0, finite=False, also={math.inf: "never"})


@dataclass(frozen=True)
class FaultsConfig:
    """Fault injection: on the emulated bus (``plant_emulator.faults.FaultPlan``, --emulate only)
    and in the host (``rig.host.injected``); times [s] of the run."""

    frame_loss: float = key(
        0.0, "", "emulated bus: the fraction of frames lost", ge=0.0, lt=1.0, rule="a fraction in [0, 1)"
    )
    seed: int = key(0, "", "emulated bus: the seed of the frame losses", ge=0)
    tpdo_stall_at: float = _at("emulated bus: the drive's TPDOs stop")
    heartbeat_loss_at: float = _at("emulated bus: the drive's heartbeat stops")
    node_reset_at: float = _at("emulated bus: the drive resets (NMT reset node)")
    overcurrent_at: float = _at("emulated bus: the drive faults on overcurrent")
    encoder_glitch_at: float = _at("emulated bus: the encoder jumps by encoder_glitch_counts")
    encoder_glitch_counts: int = key(
        2048, "increments", "emulated bus: the encoder's jump", ge=-fmt.INT32, le=fmt.INT32
    )
    law_nan_at: float = _at("host: the law's commands become NaN")
    law_error_at: float = _at("host: the law raises an exception")
    interrupt_at: float = _at("host: Ctrl-C arrives")


@dataclass(frozen=True)
class RigConfig:
    """A whole rig configuration, checked: each table's dataclass."""

    source: str  #: the file it came from
    run: RunConfig  #: ``[run]``
    bus: BusConfig  #: ``[bus]``
    emulator: EmulatorConfig  #: ``[emulator]``
    axes: tuple[AxisConfig, ...]  #: ``[[axis]]``, in order
    controller: ControllerConfig  #: ``[controller]``
    reference: ReferenceConfig  #: ``[reference]``
    faults: FaultsConfig = field(default_factory=FaultsConfig)  #: ``[faults]``

    def axis(self, name: str) -> AxisConfig:
        """The axis called ``name``.

        Parameters
        ----------
        name : str
            The axis's name.

        Returns
        -------
        AxisConfig
            Its configuration.

        Raises
        ------
        ConfigError
            If there is no such axis.
        """
        for a in self.axes:
            if a.name == name:
                return a
        raise ConfigError(f"{self.source}: no [[axis]] named {name!r}")

    @property
    def period(self) -> float:
        """[s] the run's period: ``[run] period``, else the emulator's preset's (0: none)."""
        return resolved_period(self.run, self.emulator)

    @property
    def physics(self) -> Any:
        """The emulated devices' parameters (``EmulatorConfig.physics``; None without a preset or
        device) at the run's period: the host's SYNC period is theirs (a plant stepped at its
        preset's 0.4 ms by each 1 ms SYNC runs 2.5 times slow). ``rig.config.rules`` refused at load
        a ``[run] period`` the devices cannot take; nothing is checked here."""
        physics = self.emulator.physics
        if physics is None or not self.run.period > 0.0 or physics.period == self.run.period:
            return physics
        return replace(physics, period=self.run.period)

    def as_dict(self) -> dict[str, Any]:
        """The resolved configuration, JSON-ready (inf as null).

        Returns
        -------
        dict[str, Any]
            The configuration as nested dicts.
        """

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


@dataclass(frozen=True)
class Override:
    """Values given beside the file (``rig run --fault``): ``items`` of ``table``, named in errors by
    ``source`` (the option); ``text``: command-line text, parsed by the key's type."""

    table: str  #: the table the values are of
    items: Mapping[str, Any]  #: key -> value
    source: str  #: the option that gave them, in errors
    text: bool = True  #: the values are command-line text


def resolved_period(run: RunConfig, emulator: EmulatorConfig) -> float:
    """[s] ``[run] period``, else the period of the emulator's preset (0: neither gives one)."""
    if run.period > 0.0:
        return run.period
    return float(emulator.physics.period) if emulator.physics is not None else 0.0


TABLES = {"run": RunConfig, "bus": BusConfig, "reference": ReferenceConfig, "faults": FaultsConfig}


def table(path: str, where: str, value: Any) -> dict[str, Any]:
    """``value`` as a TOML table; ConfigError naming ``path`` and ``where`` otherwise."""
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: {where} must be a table")
    return value


def replace_axis(
    cfg: RigConfig,
    name: str,
    *,
    limits: dict[str, Any] | None = None,
    units: dict[str, Any] | None = None,
    **changes: Any,
) -> RigConfig:
    """``cfg`` with the axis ``name`` changed (and its limits and units, by key).

    Parameters
    ----------
    cfg : RigConfig
        The configuration.
    name : str
        The axis.
    limits : dict[str, Any] | None, optional
        ``[axis.limits]`` keys changed.
    units : dict[str, Any] | None, optional
        ``[axis.units]`` keys changed.
    **changes : Any
        ``[[axis]]`` keys changed.

    Returns
    -------
    RigConfig
        The new configuration.
    """
    a = cfg.axis(name)
    if limits:
        changes["limits"] = replace(a.limits, **limits)
    if units:
        changes["units"] = replace(a.units, **units)
    axes = tuple(replace(x, **changes) if x.name == name else x for x in cfg.axes)
    return replace(cfg, axes=axes)
