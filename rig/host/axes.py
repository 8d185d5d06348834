"""Axis drivers from the configuration: ``kind`` -> builder, each importing its driver when used.

Like python-can's interface table: a Modbus-only rig never imports canopen's
drivers, and a CANopen rig never imports pymodbus.
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from drivers.base import AxisDriver
from drivers.errors import ConfigError
from drivers.files import read_toml
from rig.config import ABORT_CONNECTION, AxisConfig, BusConfig

__all__ = ["AXIS_DRIVERS", "open_axis"]

log = logging.getLogger(__name__)

#: ``[[axis]] kind`` -> (module, class)
AXIS_DRIVERS = {
    "cia402": ("drivers.cia402", "Cia402Axis"),
    "cia406": ("drivers.cia406", "Cia406Axis"),
    "modbus": ("drivers.modbus_inverter", "ModbusInverterAxis"),
}


def _units(a: AxisConfig) -> dict[str, float]:
    u = a.units
    return {
        k: float(v)
        for k, v in (
            ("counts_per_rev", u.counts_per_rev),
            ("rated_torque", u.rated_torque),
            ("rated_current", u.rated_current),
            ("position_unit", u.position_unit),
            ("velocity_unit", u.velocity_unit),
        )
        if v
    }


def _arguments(
    a: AxisConfig, network: Any, period: float, bus: BusConfig, realtime: bool = False
) -> tuple[tuple[Any, ...], dict[str, Any]]:
    hb = a.limits.heartbeat_timeout
    if a.kind == "cia402":
        host = (bus.host_node, a.host_timeout or 3.0 * bus.heartbeat) if bus.heartbeat > 0.0 else None
        kw: dict[str, Any] = {
            "mode": a.mode,
            "eds": a.eds or None,
            "units": _units(a),
            "sync_rpdo": a.sync_rpdo,
        }
        kw |= {"latency": a.latency, "heartbeat_timeout": hb, "pdo": a.pdo, "mode_timeout": a.mode_timeout}
        kw |= {
            "sdo_timeout": a.sdo_timeout or None,
            "sdo_retries": None if a.sdo_retries < 0 else a.sdo_retries,
            "host": host,
            "abort_connection": ABORT_CONNECTION[a.abort_connection],
            "period": period,
            "rpdo_deadline": _deadline(a, period, realtime),
            "reset_fault": a.reset_fault,
            "emcy_texts": device_emcy_texts(a.eds),
            "feedback": a.feedback,
            "axis": a.axis,
        }
        return (a.name, network, a.node_id), kw
    if a.kind == "cia406":
        kw = {"period": period, "eds": a.eds or None, "heartbeat_timeout": hb}
        return (a.name, network, a.node_id), kw | {"speed_from_position": a.speed_from_position}
    kw = {"unit": a.unit, "host": a.host or None, "port": a.port, "serial": a.serial or None}
    return (a.name, a.map), kw | {"baudrate": a.baudrate}


def device_emcy_texts(eds: str) -> dict[int, str]:
    """The ``[emcy]`` table of the device profile next to ``eds`` (same name, .toml), if any."""
    if not eds:
        return {}
    profile = Path(eds).with_suffix(".toml")
    if not profile.exists():
        return {}
    try:
        table = read_toml(profile, what="device profile").get("emcy", {})
    except ConfigError as exc:  # the texts only explain EMCY codes: the run goes on without them
        log.warning("EMCY texts not read: %s", exc)
        return {}
    if not isinstance(table, dict):
        return {}
    out: dict[int, str] = {}
    for key, text in table.items():
        try:
            out[int(key, 0)] = str(text)
        except ValueError:
            continue
    return out


def _deadline(a: AxisConfig, period: float, realtime: bool) -> float:
    """The toolkit drive's deadline on the commands [s]: ``rpdo_deadline_periods`` periods, in
    real time at least ``rpdo_deadline`` [s]; 0: none."""
    if not a.rpdo_deadline_periods:
        return 0.0
    return max(a.rpdo_deadline_periods * period, a.rpdo_deadline if realtime else 0.0)


def open_axis(
    a: AxisConfig, *, network: Any, period: float, bus: BusConfig | None = None, realtime: bool = False
) -> AxisDriver:
    """The driver of axis ``a`` (nothing is sent yet).

    Parameters
    ----------
    a : AxisConfig
        The axis's ``[[axis]]`` table.
    network : Any
        The CANopen network a CANopen axis joins (unused by Modbus axes).
    period : float
        The loop's period [s].
    bus : BusConfig | None
        ``[bus]`` (None: its defaults).
    realtime : bool
        The run is in real time (a real-time floor of the drive's deadline).

    Returns
    -------
    AxisDriver
        The axis's driver, its rest speed and time set from ``[axis.limits]``.
    """
    module, name = AXIS_DRIVERS[a.kind]
    cls: Callable[..., AxisDriver] = getattr(importlib.import_module(module), name)
    args, kwargs = _arguments(a, network, period, bus or BusConfig(), realtime)
    axis = cls(*args, **kwargs)
    axis.rest_speed, axis.rest_time = a.limits.rest_speed, a.limits.rest_time
    return axis
