"""``rig emulate``: the plant emulator as its own process.

On a python-can bus (``--interface socketcan --channel vcan0``, or any other
interface) the devices answer real frames; without kernel CAN, the emulator
serves socketcand's rawmode on 127.0.0.1 (``--socketcand-port``), which
python-can's ``socketcand`` interface speaks as a client. Time is real: the
devices step their physics one period per SYNC the host sends, and send
heartbeats on the wall clock. With ``--time lockstep`` an event RPDO counts as
received at the SYNC it answers, so a host that waits for each answer gets
exactly the in-process trajectory. Ctrl-C (or SIGTERM) stops it cleanly.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections.abc import Mapping
from typing import Any

import can
import canopen

from drivers.errors import ConfigError
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.lockstep import SyncHub, attach_network
from plant_emulator.parameters import PREFIX, field_types
from plant_emulator.presets import PRESETS, build_preset
from plant_emulator.socketcand_server import SocketcandServer

__all__ = ["preset_values", "run_emulator", "run_modbus_emulator"]

log = logging.getLogger(__name__)


def _locked_notify(network: Any, lock: threading.RLock) -> None:
    notify = network.notify

    def locked(can_id: int, data: bytearray, timestamp: float) -> None:
        with lock:
            notify(can_id, data, timestamp)

    network.notify = locked


def _parse(kind: Any, text: str) -> object:
    """``text`` as a value of field type ``kind`` (int, float or a fraction, str, a Literal)."""
    if kind is int:
        return int(text, 0)
    if kind is float:
        num, slash, den = text.partition("/")
        return float(num) / float(den) if slash else float(num)
    return text


def preset_values(name: str, texts: Mapping[str, str]) -> dict[str, object]:
    """``NAME=VALUE`` texts typed by the fields of preset ``name``; the emulator checks the rest."""
    kinds = field_types(PRESETS[name]) if name in PRESETS else {}
    values: dict[str, object] = {}
    for given, text in texts.items():
        kind = kinds.get(given.removeprefix(PREFIX))
        try:
            values[given] = _parse(kind, text) if isinstance(text, str) else text
        except (ValueError, ZeroDivisionError):
            raise ValueError(
                f"preset parameter {given}={text!r}: not a {getattr(kind, '__name__', kind)}"
            ) from None
    return values


def run_emulator(
    preset: str,
    overrides: dict[str, str],
    *,
    interface: str | None = None,
    channel: str | None = None,
    host: str = "127.0.0.1",
    port: int = 29536,
    stop: threading.Event | None = None,
    ready: Any = None,
    lockstep: bool = False,
) -> int:
    """Run until Ctrl-C (or ``stop`` is set); ``ready(port)`` is called once serving."""
    stop = stop or threading.Event()
    lock = threading.RLock()
    network = canopen.Network()
    server: SocketcandServer | None = None
    bus: can.BusABC | None = None
    if interface:
        try:
            bus = can.Bus(interface=interface, channel=channel, ignore_config=True)
        except (can.CanError, OSError, ValueError) as exc:
            raise ConfigError(
                f"--interface {interface} --channel {channel}: cannot open the bus: {exc}"
            ) from exc
        network.bus = bus
        _locked_notify(network, lock)
        network.notifier = can.Notifier(bus, network.listeners, 0.5)
        where = f"{interface}:{channel}"
    else:
        hub = SyncHub()
        attach_network(network, hub.bus(queue=False, channel="emulator"))
        try:
            server = SocketcandServer(hub, lock, host=host, port=port)
        except OSError as exc:
            raise ConfigError(f"--socketcand-port {port}: cannot listen on {host}: {exc}") from exc
        where = f"socketcand://{host}:{server.port}"
    try:
        with lock:
            devices: list[EmulatedNode]
            devices, period = build_preset(preset, network, preset_values(preset, overrides))
            for d in devices:
                if hasattr(d, "lockstep"):
                    d.lockstep = lockstep
                d.boot()
        if server is not None:
            server.start()
        log.info(
            "emulating %s (nodes %s, period %g s) on %s", preset, [d.node_id for d in devices], period, where
        )
        print(f"rig emulate: {preset} on {where}; Ctrl-C stops", flush=True)
        if ready is not None:
            ready(server.port if server else 0)
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
        while not stop.is_set():
            with lock:
                now = time.time()
                for d in devices:
                    d.tick(now)
            stop.wait(0.01)
    except KeyboardInterrupt:
        log.info("interrupted")
    finally:
        if server is not None:
            server.stop()
        if bus is not None:
            if network.notifier is not None:
                network.notifier.stop()
            bus.shutdown()
        print("rig emulate: stopped", flush=True)
    return 0


def run_modbus_emulator(
    family: str,
    overrides: dict[str, str],
    *,
    host: str = "127.0.0.1",
    port: int = 5020,
    serial: str | None = None,
) -> int:
    """Serve an emulated Modbus inverter (TCP on ``host``:``port``, or RTU on ``serial``) until Ctrl-C.

    ``overrides`` set ``InverterModel`` fields by name (accel, slip, max_speed, comm_loss_timeout, ...).
    """
    import asyncio
    import dataclasses

    from plant_emulator.modbus_inverter import InverterModel, default_model, serve_rtu, serve_tcp

    kinds = {f.name: f.type for f in dataclasses.fields(InverterModel)}
    values: dict[str, float] = {}
    for name, text in overrides.items():
        if kinds.get(name) != "float":
            known = ", ".join(k for k, v in kinds.items() if v == "float")
            raise ConfigError(f"--param {name}: not a parameter of the inverter; known: {known}")
        try:
            values[name] = float(text)
        except ValueError:
            raise ConfigError(f"--param {name}={text!r}: not a number") from None
    try:
        model = default_model(family, **values)
    except ValueError as exc:
        raise ConfigError(f"--modbus-map {family}: {exc}") from exc
    where = f"RTU on {serial}" if serial else f"TCP {host}:{port}"
    print(f"rig emulate: Modbus inverter {family} on {where}; Ctrl-C stops", flush=True)
    server = serve_rtu(model, port=serial) if serial else serve_tcp(model, host=host, port=port)
    try:
        asyncio.run(server)
    except KeyboardInterrupt:
        log.info("interrupted")
    except OSError as exc:
        raise ConfigError(f"cannot serve Modbus {where}: {exc}") from exc
    finally:
        print("rig emulate: stopped", flush=True)
    return 0
