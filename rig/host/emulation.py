"""The emulated world of a ``--emulate`` run, in this process.

The configured preset on the in-process lock-step bus (``plant_emulator.lockstep``),
an emulated Modbus inverter for every Modbus axis (TCP on 127.0.0.1, or RTU over a
pseudo-terminal pair when the axis names a serial device), and the fault
injector of ``[faults]``. The host's canopen network is ``network``; Modbus axes
are pointed at their inverters by ``endpoint``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import canopen

from drivers.errors import ConfigError
from drivers.maps import modbus_map
from plant_emulator.device_profile import DeviceProfile, device_profile
from plant_emulator.faults import FaultInjector, FaultPlan
from plant_emulator.lockstep import LockstepBench
from plant_emulator.presets import PRESETS
from plant_emulator.presets import preset_params as plant_preset_params
from rig.config import AxisConfig, RigConfig
from rig.config_checks import check_period
from rig.params import field_types, typed_values

__all__ = ["Emulation", "emulated_period", "inverter_model", "preset_params"]

#: the fields of FaultsConfig that the emulator injects (the others are host-side)
EMULATOR_FAULTS = tuple(f.name for f in dataclasses.fields(FaultPlan))
#: modbus model fields that are not parameters
_MODEL_FIXED = ("regmap", "load")


def preset_params(
    name: str,
    params: dict[str, Any],
    source: str,
    *,
    text: bool = False,
    base: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """``params`` typed against the preset ``name``'s parameters (``text``: command-line text) and
    checked in their ranges over ``base`` (a twin's own values); ConfigError naming the bad one."""
    if name not in PRESETS:
        raise ConfigError(f"{source}: unknown preset {name!r}; known: {', '.join(PRESETS)}")
    schema = PRESETS[name]
    aliases = {f"plant.{k}": k for k in field_types(schema)}
    typed = typed_values(schema, params, source, aliases=aliases, text=text)
    try:
        period = plant_preset_params(name, {**(base or {}), **typed}).period
    except ValueError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    check_period(f"{source}:", "period" if "period" in aliases.values() else "ratio/f_line", period)
    return typed


def _physics(cfg: RigConfig) -> tuple[str, dict[str, Any], DeviceProfile | None]:
    """(preset, typed ``[emulator.params]``, the twin's profile or None) of ``cfg``; ConfigError
    naming the file, the key and the value (the preset's own range checks included)."""
    src, device = cfg.source, cfg.emulator.device
    profile = None
    if device:
        try:
            profile = device_profile(device)
        except ConfigError as exc:
            raise ConfigError(f"{src}: [emulator] device = {device!r}: {exc}") from None
    name = profile.physics if profile else cfg.emulator.preset
    if name not in PRESETS:
        raise ConfigError(f"{src}: [emulator] preset = {name!r}: unknown; known: {', '.join(PRESETS)}")
    what = f"device {device}" if device else f"preset {name}"
    base = profile.params if profile else None
    params = preset_params(name, cfg.emulator.params, f"{src}: [emulator.params] of {what}", base=base)
    return name, _at_run_period(cfg, name, params, base, what), profile


def _at_run_period(
    cfg: RigConfig, name: str, params: dict[str, Any], base: Mapping[str, Any] | None, what: str
) -> dict[str, Any]:
    """``params`` with the emulated devices' period set to ``[run] period`` where that is given
    (the host's SYNC period is theirs: a plant stepped at its preset's 0.4 ms by each 1 ms SYNC
    runs 2.5 times slow); ConfigError where [emulator.params] gives another period, or the
    preset's period is not a parameter of its own (grid-converter's ratio/f_line)."""
    period = cfg.run.period
    if not period > 0.0:
        return params
    own = float(plant_preset_params(name, {**(base or {}), **params}).period)
    if abs(own - period) <= 1e-9 * period:
        return params
    head = f"{cfg.source}: [run] period = {period:g} s, but the emulated devices run at {own:g} s"
    if "period" not in field_types(PRESETS[name]):
        raise ConfigError(
            f"{head} (ratio/f_line of {what}): leave [run] period out and set the period through "
            "[emulator.params] ratio and f_line"
        )
    if "period" in params:
        raise ConfigError(
            f"{head} ([emulator.params] period of {what}): give the period once, in [run] or in "
            "[emulator.params]"
        )
    return {**params, "period": period}


def emulated_period(cfg: RigConfig) -> float:
    """The period [s] of ``cfg`` run with ``--emulate``: ``[run] period``, else the preset's (or
    the twin's), known before anything is built; ConfigError when there is none."""
    canopen_axes = [a.name for a in cfg.axes if a.kind != "modbus"]
    if not (cfg.emulator.preset or cfg.emulator.device):
        if canopen_axes:
            raise ConfigError(
                f"{cfg.source}: --emulate needs [emulator] preset or device for the CANopen axes "
                f"{canopen_axes}"
            )
        if not cfg.run.period > 0.0:
            raise ConfigError(f"{cfg.source}: [run] period must be set (> 0 s): no preset gives one")
        period = cfg.run.period
    else:
        name, params, profile = _physics(cfg)
        merged = {**(profile.params if profile else {}), **params}
        period = cfg.run.period or float(plant_preset_params(name, merged).period)
    for a in cfg.axes:
        if a.kind == "modbus":
            inverter_model(cfg, a, period)  # its values checked before anything is built
    return period


def inverter_model(cfg: RigConfig, a: AxisConfig, period: float) -> Any:
    """The emulated inverter of Modbus axis ``a`` (``[emulator.inverter]``), polled every
    ``period`` [s]; ConfigError naming the file, the key and the value."""
    from plant_emulator.modbus_inverter import InverterModel

    where = f"{cfg.source}: [emulator.inverter]"
    values = typed_values(InverterModel, cfg.emulator.inverter, where, fixed=_MODEL_FIXED)
    try:
        model = InverterModel(modbus_map(a.map), **values)
    except ValueError as exc:
        raise ConfigError(f"{where}: {exc}") from exc
    if not period < model.comm_loss_timeout:  # the host polls once a period, on either clock
        raise ConfigError(
            f"{cfg.source}: [run] period {period:g} s is not shorter than the emulated inverter's "
            f"comm_loss_timeout {model.comm_loss_timeout:g} s: it would trip between two cycles "
            "(raise [emulator.inverter] comm_loss_timeout)"
        )
    return model


class Emulation:
    """See the module docstring; ``close`` stops everything it started."""

    def __init__(self, cfg: RigConfig) -> None:
        #: lock-step: the inverters' physics is stepped by the host; real time: on the wall clock
        self._dt = None if cfg.run.time == "lockstep" else 0.005
        self.bench: LockstepBench | None = None
        self.injector: FaultInjector | None = None
        self.inverters: dict[str, tuple[Any, Any]] = {}  #: axis name -> (InverterModel, InverterServer)
        self._links: list[Any] = []
        self._taps: list[Callable[[Any], None]] = []  #: see ``add_tap``
        self._endpoints: dict[str, dict[str, Any]] = {}
        self.period = emulated_period(cfg)
        if cfg.emulator.preset or cfg.emulator.device:
            self.bench = self._bench(cfg)
        self.network: Any = self.bench.host if self.bench else canopen.Network()
        try:
            for a in cfg.axes:
                if a.kind == "modbus":
                    self._start_inverter(cfg, a)
            self._inject(cfg)
        except BaseException:
            self.close()
            raise

    def _bench(self, cfg: RigConfig) -> LockstepBench:
        """The preset's devices, or the twin of ``device`` (whose EDS its axis then uses)."""
        name, params, profile = _physics(cfg)
        try:
            bench = LockstepBench(name, params, device=profile)
        except ConfigError:
            raise
        except (ValueError, OverflowError) as exc:  # a value the devices cannot hold, found building them
            what = f"device {cfg.emulator.device}" if profile else f"preset {name}"
            given = ", ".join(f"{k} = {v!r}" for k, v in cfg.emulator.params.items())
            raise ConfigError(f"{cfg.source}: [emulator.params] of {what} ({given}): {exc}") from exc
        if profile is not None:
            for a in cfg.axes:
                if a.kind == "cia402" and a.node_id == profile.node_id and not a.eds:
                    self._endpoints[a.name] = {"eds": str(profile.eds)}
        return bench

    def _start_inverter(self, cfg: RigConfig, a: AxisConfig) -> None:
        from plant_emulator.modbus_inverter import InverterServer
        from plant_emulator.pty_link import PtyLink

        model = inverter_model(cfg, a, self.period)
        try:
            if a.serial:  # RTU: the inverter on one end of a pty pair, the axis on the other
                link = PtyLink()
                self._links.append(link)
                server = InverterServer(
                    model, serial=link.port_b, baudrate=a.baudrate, unit=a.unit, dt=self._dt
                )
                self._endpoints[a.name] = {"serial": link.port_a, "host": ""}
            else:
                server = InverterServer(model, unit=a.unit, dt=self._dt)
        except ValueError as exc:
            raise ConfigError(f"{cfg.source}: [[axis]] {a.name!r}: {exc}") from exc
        server.start()
        if not a.serial:
            self._endpoints[a.name] = {"host": "127.0.0.1", "port": server.port, "serial": ""}
        self.inverters[a.name] = (model, server)

    def _inject(self, cfg: RigConfig) -> None:
        plan = FaultPlan(**{k: getattr(cfg.faults, k) for k in EMULATOR_FAULTS})
        if plan.active:
            if self.bench is None:
                raise ConfigError(f"{cfg.source}: [faults] of the CAN bus need a CANopen [emulator] preset")
            self.injector = FaultInjector(plan, self.bench.hub, self.bench.devices[0])

    def endpoint(self, a: AxisConfig) -> AxisConfig:
        """``a`` pointed at its emulated device."""
        return dataclasses.replace(a, **self._endpoints.get(a.name, {}))

    @property
    def sync(self) -> Callable[[], None] | None:
        return self.bench.sync if self.bench else None

    @property
    def steppers(self) -> list[Callable[[float], None]]:
        """The in-process Modbus inverters' physics, stepped one period per cycle in lock-step."""
        if self._dt is not None:
            return []
        return [model.step for model, _ in self.inverters.values()]

    @property
    def devices(self) -> list[Any]:
        return self.bench.devices if self.bench else []

    def add_tap(self, tap: Callable[[Any], None]) -> None:
        """``tap`` sees every frame on the hub; the host's marked Tx, the devices' Rx."""
        if self.bench is not None:
            self.bench.hub.tx_channel = "host"
            self.bench.hub.taps.append(tap)
            self._taps.append(tap)

    def remove_tap(self, tap: Callable[[Any], None]) -> None:
        if tap in self._taps:
            self._taps.remove(tap)
        if self.bench is not None:
            if tap in self.bench.hub.taps:
                self.bench.hub.taps.remove(tap)
            if not self._taps:
                self.bench.hub.tx_channel = None

    def close(self) -> None:
        """Stop the inverters, the fault injector and the bus (idempotent)."""
        for _, server in self.inverters.values():
            server.stop()
        for link in self._links:
            link.close()
        self._links.clear()
        if self.injector is not None:
            self.injector.shutdown()
            self.injector = None
        if self.bench is not None:
            self.bench.close()
