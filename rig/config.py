"""The rig configuration: a TOML file loaded into frozen dataclasses.

Sections and keys (SI units; see ``examples/`` for complete files)::

    [run]        duration [s], time ("lockstep" | "realtime"), output (directory), name,
                 period [s] (default: the emulator preset's), trace (write trace.asc, default true)
    [bus]        interface, channel, bitrate, host, port       (ignored with --emulate)
    [emulator]   preset, and [emulator.params] NAME = "VALUE"   (for --emulate)
    [drive]      node_id, mode (voltage | cst | csv | csp | pv | dq-voltage), sync_rpdo, latency [s],
                 enable_timeout [s], eds (the drive's EDS/DCF; default the toolkit's)
    [controller] kind (position-servo | pi-speed | idtsm-speed), and its parameters
    [reference]  kind (smooth-move | step | constant), distance, duration, start, value
    [limits]     command, speed [rad/s], position_min/max [rad], current [A],
                 watchdog_periods, heartbeat_timeout [s] (0: off)
    [faults]     fault injection with --emulate: frame_loss, seed, tpdo_stall_at, heartbeat_loss_at,
                 node_reset_at, overcurrent_at, encoder_glitch_at [s], encoder_glitch_counts

An unknown section or key, or a value of the wrong type, is a ``ConfigError``
naming the file and the key.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "BusConfig",
    "ControllerConfig",
    "DriveConfig",
    "EmulatorConfig",
    "FaultsConfig",
    "LimitsConfig",
    "ReferenceConfig",
    "RigConfig",
    "RunConfig",
    "load_config",
]


@dataclass(frozen=True)
class RunConfig:
    duration: float = 3.0
    time: str = "lockstep"
    output: str = "runs"
    name: str = "run"
    period: float = 0.0  #: 0: the emulator preset's period
    trace: bool = True  #: write the CAN trace (trace.asc)


@dataclass(frozen=True)
class BusConfig:
    interface: str = "socketcand"
    channel: str = "can0"
    bitrate: int = 0
    host: str = "127.0.0.1"
    port: int = 29536


@dataclass(frozen=True)
class EmulatorConfig:
    preset: str = "dc-servo"
    params: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class DriveConfig:
    node_id: int = 1
    mode: str = "voltage"
    sync_rpdo: bool = True
    latency: float = 0.0
    enable_timeout: float = 1.0
    eds: str = ""  #: the drive's EDS/DCF file (empty: the toolkit's CiA 402 EDS)


@dataclass(frozen=True)
class ControllerConfig:
    kind: str = "position-servo"
    params: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class ReferenceConfig:
    kind: str = "smooth-move"
    distance: float = 10.0
    duration: float = 1.0
    start: float = 0.0
    value: float = 0.0


@dataclass(frozen=True)
class LimitsConfig:
    command: float = math.inf
    speed: float = math.inf
    position_min: float = -math.inf
    position_max: float = math.inf
    current: float = math.inf
    watchdog_periods: int = 3
    heartbeat_timeout: float = 0.0


@dataclass(frozen=True)
class FaultsConfig:
    """Fault injection of the emulator (``plant_emulator.faults.FaultPlan``); --emulate only."""

    frame_loss: float = 0.0
    seed: int = 0
    tpdo_stall_at: float = math.inf
    heartbeat_loss_at: float = math.inf
    node_reset_at: float = math.inf
    overcurrent_at: float = math.inf
    encoder_glitch_at: float = math.inf
    encoder_glitch_counts: int = 2048


@dataclass(frozen=True)
class RigConfig:
    source: str
    run: RunConfig
    bus: BusConfig
    emulator: EmulatorConfig
    drive: DriveConfig
    controller: ControllerConfig
    reference: ReferenceConfig
    limits: LimitsConfig
    faults: FaultsConfig = field(default_factory=FaultsConfig)

    def as_dict(self) -> dict[str, Any]:
        """The resolved configuration, JSON-ready (inf as null)."""

        def clean(v: Any) -> Any:
            if isinstance(v, float) and not math.isfinite(v):
                return None
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            return v

        out: dict[str, Any] = {"source": self.source}
        for f in fields(self):
            if f.name != "source":
                section = getattr(self, f.name)
                out[f.name] = {g.name: clean(getattr(section, g.name)) for g in fields(section)}
        return out


_SECTIONS: dict[str, type] = {
    "run": RunConfig,
    "bus": BusConfig,
    "emulator": EmulatorConfig,
    "drive": DriveConfig,
    "controller": ControllerConfig,
    "reference": ReferenceConfig,
    "limits": LimitsConfig,
    "faults": FaultsConfig,
}


def _coerce(path: str, key: str, value: Any, default: Any) -> Any:
    where = f"{path}: [{key.split('.', maxsplit=1)[0]}] {key.split('.', 1)[-1]}"
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"{where} = {value!r}: expected true or false")
        return value
    if isinstance(default, int) and not isinstance(default, bool):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where} = {value!r}: expected an integer")
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where} = {value!r}: expected a number")
        if math.isnan(value):
            raise ConfigError(f"{where} = {value!r}: NaN is not allowed")
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f"{where} = {value!r}: expected a string")
        return value
    return value


def _section(path: str, name: str, table: Any) -> Any:
    cls = _SECTIONS[name]
    if not isinstance(table, dict):
        raise ConfigError(f"{path}: [{name}] must be a table")
    defaults = cls()
    known = {f.name for f in fields(cls)}
    values: dict[str, Any] = {}
    if name == "controller":  # kind, then the controller's own numeric parameters
        params = {}
        for key, value in table.items():
            if key == "kind":
                values["kind"] = _coerce(path, "controller.kind", value, "")
            elif isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(f"{path}: [controller] {key} = {value!r}: expected a number")
            else:
                params[key] = float(value)
        values["params"] = params
        return cls(**values)
    for key, value in table.items():
        if key not in known:
            raise ConfigError(f"{path}: unknown key {key!r} in [{name}]; known: {', '.join(sorted(known))}")
        if name == "emulator" and key == "params":
            if not isinstance(value, dict):
                raise ConfigError(f"{path}: [emulator.params] must be a table")
            values[key] = {str(k): str(v) for k, v in value.items()}
            continue
        values[key] = _coerce(path, f"{name}.{key}", value, getattr(defaults, key))
    return cls(**values)


def load_config(path: str | Path) -> RigConfig:
    """Load and check a rig configuration file."""
    p = Path(path)
    try:
        doc = tomllib.loads(p.read_text())
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read: {exc.strerror}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML: {exc}") from exc
    for key in doc:
        if key not in _SECTIONS:
            raise ConfigError(f"{p}: unknown section [{key}]; known: {', '.join(_SECTIONS)}")
    sections = {name: _section(str(p), name, doc.get(name, {})) for name in _SECTIONS}
    cfg = RigConfig(source=str(p), **sections)
    if cfg.run.time not in ("lockstep", "realtime"):
        raise ConfigError(f"{p}: [run] time = {cfg.run.time!r}: expected 'lockstep' or 'realtime'")
    if cfg.run.duration <= 0.0:
        raise ConfigError(f"{p}: [run] duration = {cfg.run.duration!r}: must be > 0 s")
    if not 1 <= cfg.drive.node_id <= 127:
        raise ConfigError(f"{p}: [drive] node_id = {cfg.drive.node_id}: must be 1..127")
    return cfg
