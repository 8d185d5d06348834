"""``rig emulate``: the plant emulator as its own process.

On a python-can bus (``--interface socketcan --channel vcan0``, or any other
interface) the devices answer real frames; without kernel CAN, the emulator
serves socketcand's rawmode on 127.0.0.1 (``--port``), which
python-can's ``socketcand`` interface speaks as a client. Time is real: the
devices run on their own monotonic clock (``plant_emulator.clock``), their
physics in whole periods of the preset whether SYNCs come or not, and a SYNC
latches the feedback. With ``--time lockstep`` time is the SYNCs': each steps
one period, an event RPDO counts as received at the SYNC it answers, so a host
that waits for each answer gets exactly the in-process trajectory. Ctrl-C (or
SIGTERM) stops it cleanly; SIGUSR1 puts the plant back at rest at angle zero between
runs (``rest_plants``: refused while a drive is enabled). A drive's NMT reset does not:
it lets go of its axis and the shaft keeps turning, as a real drive's does.
"""

from __future__ import annotations

import gc
import logging
import pathlib
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import can
import canopen

from drivers.bus_time import DEFAULT_BITRATE
from drivers.errors import CommunicationError, ConfigError
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.clock import WorldClock
from plant_emulator.lockstep import SyncHub, attach_network
from plant_emulator.shaft import shafts_of
from plant_emulator.socketcand_server import SocketcandServer
from rig.host.realtime import Grant, RealtimeRequest, collect_young, request

__all__ = ["World", "rest_plants", "run_emulator", "run_modbus_emulator"]

log = logging.getLogger(__name__)

#: how often [s] the real-time emulator brings its devices to now when no frame does (each SYNC
#: does too); the physics always advances in whole periods of the preset, so this is only how
#: stale an SDO read or a supervision check may be
_TICK = 0.002


def _locked_notify(network: Any, lock: threading.RLock) -> None:
    notify = network.notify

    def locked(can_id: int, data: bytearray, timestamp: float) -> None:
        with lock:
            notify(can_id, data, timestamp)

    network.notify = locked


def _transport(
    network: Any,
    lock: threading.RLock,
    *,
    interface: str | None,
    channel: str | None,
    host: str,
    port: int,
    bitrate: float = DEFAULT_BITRATE,
) -> tuple[Any, SocketcandServer | None, str]:
    """Join ``network`` to a python-can bus (``interface``) or a socketcand server whose bus
    carries ``bitrate`` [bit/s]: (bus, server, where)."""
    if interface:
        try:
            bus = can.Bus(interface=interface, channel=channel, ignore_config=True)
        except (can.CanError, OSError, ValueError) as exc:  # exit code 1, as rig run's bus
            raise CommunicationError(
                f"--interface {interface} --channel {channel}: cannot open the bus: {exc}"
            ) from exc
        network.bus = bus
        _locked_notify(network, lock)
        network.notifier = can.Notifier(bus, network.listeners, 0.5)
        return bus, None, f"{interface}:{channel}"
    hub = SyncHub()
    emulator_bus = hub.bus(queue=False, channel="emulator")
    try:
        server = SocketcandServer(hub, lock, host=host, port=port, bitrate=bitrate)
    except OSError as exc:
        emulator_bus.shutdown()
        raise ConfigError(f"--host {host} --port {port}: cannot listen: {exc}") from None
    attach_network(network, emulator_bus)
    return None, server, f"socketcand://{host}:{server.port}"


#: what builds the emulated world on a network: (devices, SYNC period [s])
World = Callable[[canopen.Network], tuple[list[EmulatedNode], float]]


def run_emulator(
    world: World,
    label: str,
    *,
    interface: str | None = None,
    channel: str | None = None,
    host: str = "127.0.0.1",
    port: int = 29536,
    stop: threading.Event | None = None,
    ready: Any = None,
    lockstep: bool = False,
    realtime: RealtimeRequest | None = None,
    bitrate: float = DEFAULT_BITRATE,
) -> int:
    """Run until Ctrl-C (or ``stop`` is set); ``ready(port)`` is called once serving; ``bitrate``
    [bit/s]: the socketcand server's bus. In real time, ``realtime`` is asked for this thread (the
    clock) before the server starts, so the threads that carry the frames, which it starts,
    inherit its policy and CPU (``rig.host.realtime``).

    Parameters
    ----------
    world : World
        The emulated devices.
    label : str
        What is served, in its first line.
    interface, channel : str | None, optional
        A python-can bus to serve on (None: socketcand).
    host, port, optional
        The socketcand server's address.
    stop : threading.Event | None, optional
        Set to end it (None: Ctrl-C only).
    ready : Any, optional
        ``ready(port)`` once serving.
    lockstep : bool, optional
        The devices' time is the SYNC count (else the clock).
    realtime : RealtimeRequest | None, optional
        Asked for the clock's thread before the server starts.
    bitrate : float, optional
        [bit/s] the socketcand server's bus.

    Returns
    -------
    int
        The exit status.
    """
    lock = threading.RLock()
    network = canopen.Network()
    bus, server, where = _transport(
        network, lock, interface=interface, channel=channel, host=host, port=port, bitrate=bitrate
    )
    emulation = _Emulation(network, lock, bus, server, where)
    try:
        emulation.serve(world, label, stop or threading.Event(), ready, lockstep=lockstep, realtime=realtime)
    except KeyboardInterrupt:
        log.info("interrupted")
    finally:
        emulation.close()
    return 0


@dataclass
class _Emulation:
    """The emulator's network and transport, joined: what serving and closing them share."""

    network: canopen.Network
    lock: threading.RLock  #: held by whoever touches the devices
    bus: Any  #: the python-can bus served on (None: socketcand)
    server: SocketcandServer | None  #: the socketcand server (None: a python-can bus)
    where: str  #: where it serves, in words
    collect: Callable[[], bool] | None = None  #: real time: young garbage collected in the slack

    def serve(
        self,
        world: World,
        label: str,
        stop: threading.Event,
        ready: Any,
        *,
        lockstep: bool,
        realtime: RealtimeRequest | None,
    ) -> None:
        """Boot the world, start serving, say so (``ready(port)``) and serve until ``stop``."""
        devices, period = _boot(world, self.network, self.lock, lockstep=lockstep)
        grant: Grant | None = None
        if not lockstep and realtime is not None:
            self.collect = _collect_in_the_slack()
            grant = request(realtime)
        with self.lock:
            clock = None if lockstep else WorldClock(devices)  # its time starts now
        server = self.server
        if server is not None:
            server.idle = self.collect  # the frames' thread, once a round's answers are out
            server.start()
        rest = _signals(stop)  # before anyone is told we serve
        _announce(label, devices, period, self.where, grant)
        if ready is not None:
            ready(server.port if server else 0)
        collect = None if server is not None else self.collect  # where no frames' thread does
        _serve(stop, rest, lock=self.lock, devices=devices, clock=clock, collect=collect)

    def close(self) -> None:
        """The collector back on, the transport closed, and the last line on stdout."""
        if self.collect is not None:
            gc.enable()
        _close(self.server, self.bus, self.network)
        print("rig emulate: stopped", flush=True)


def _signals(stop: threading.Event) -> threading.Event:
    """On the main thread, SIGTERM sets ``stop`` and SIGUSR1 the event returned (the plants to rest)."""
    rest = threading.Event()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
        signal.signal(signal.SIGUSR1, lambda signum, frame: rest.set())
    return rest


def _announce(
    label: str, devices: list[EmulatedNode], period: float, where: str, grant: Grant | None
) -> None:
    """What is served, where, and the real-time grant: logged, and the first line on stdout."""
    nodes = [d.node_id for d in devices]
    log.info("emulating %s (nodes %s, period %g s) on %s", label, nodes, period, where)
    granted = f" ({grant.describe()})" if grant is not None else ""
    print(
        f"rig emulate: {label} on {where}{granted}; Ctrl-C stops, SIGUSR1 puts the plant at rest",
        flush=True,
    )


def _boot(
    world: World, network: canopen.Network, lock: threading.RLock, *, lockstep: bool
) -> tuple[list[EmulatedNode], float]:
    """The world's devices built on ``network`` and booted, each in lock-step where asked and it has
    the choice; (devices, period [s])."""
    with lock:
        devices: list[EmulatedNode]
        devices, period = world(network)
        for d in devices:
            if hasattr(d, "lockstep"):
                d.lockstep = lockstep
            d.boot()
    return devices, period


def _collect_in_the_slack() -> Callable[[], bool]:
    """Real time: the collector off, the world's objects frozen out of its collections; the young
    garbage then goes in the slack of a round (what is returned, ``collect_young``)."""
    gc.collect()
    gc.freeze()  # the world built: its objects are not traversed by the collections to come
    gc.disable()  # none in a SYNC's answer (one took 90 us median, 0.5 ms at p90, 15 a second)
    return collect_young


def _serve(
    stop: threading.Event,
    rest: threading.Event,
    *,
    lock: threading.RLock,
    devices: list[EmulatedNode],
    clock: WorldClock | None,
    collect: Callable[[], bool] | None,
) -> None:
    """Serve until ``stop``: the plants at rest when ``rest`` is set; in real time (``clock``) the
    next SYNC's state prepared within the lead and the young garbage collected here (``collect``:
    where no frames' thread of ours does)."""
    while not stop.is_set():
        if rest.is_set():
            rest.clear()
            with lock:
                rest_plants(devices)
        if clock is not None:  # real time: the devices' own clock runs, SYNC or not
            with lock:
                clock.prepare()  # the next SYNC's state, once it is within the lead
            if collect is not None:
                collect()
            # up to the next period's preparation (or the tick), never less than a lead:
            # the receive path must run however slow the machine is (WorldClock.pause)
            stop.wait(clock.pause(_TICK))
        else:
            stop.wait(0.1)


def _close(server: SocketcandServer | None, bus: Any, network: canopen.Network) -> None:
    """The socketcand server and the emulator's bus on its hub, or the python-can bus, closed."""
    if server is not None:
        server.stop()
        if network.bus is not None:  # the emulator's own bus on the hub
            network.bus.shutdown()
    if bus is not None:
        if network.notifier is not None:
            network.notifier.stop()
        bus.shutdown()


def rest_plants(devices: list[EmulatedNode]) -> bool:
    """Every shaft of ``devices`` back to rest at angle zero (``Shaft.rest``), unless a drive on
    one is enabled (a turning motor is not zeroed under its drive): then nothing, and a warning
    naming the nodes. True when done.

    Parameters
    ----------
    devices : list[EmulatedNode]
        The emulated nodes.

    Returns
    -------
    bool
        Done (no drive enabled).
    """
    enabled = [d.node_id for d in devices if getattr(d, "enabled", False)]
    if enabled:
        log.warning("plant reset refused: node(s) %s enabled; disable them first", enabled)
        return False
    for shaft in shafts_of(devices):
        shaft.rest()
    print("rig emulate: the plant is back at rest (angle 0, speed 0)", flush=True)
    return True


def run_modbus_emulator(
    family: str,
    params: dict[str, str],
    *,
    host: str = "127.0.0.1",
    port: int = 5020,
    serial: str | None = None,
) -> int:
    """Serve an emulated Modbus inverter (TCP on ``host``:``port``, or RTU on ``serial``) until Ctrl-C.

    ``params`` set ``InverterModel`` fields by name (accel, slip, max_speed, comm_loss_timeout, ...).

    Parameters
    ----------
    family : str
        The register map.
    params : dict[str, str]
        ``InverterModel`` fields by name.
    host, port, optional
        Modbus TCP's address.
    serial : str | None, optional
        A serial device for RTU (None: TCP).

    Returns
    -------
    int
        The exit status.

    Raises
    ------
    ConfigError
        If the map is unknown, the serial device missing, or it cannot serve.
    """
    import asyncio

    from plant_emulator.modbus_inverter import default_model, serve_rtu, serve_tcp
    from rig.config.emulator import inverter_values

    values = inverter_values(params, "rig emulate: --param", text=True)
    try:
        model = default_model(family, **values)
    except ValueError as exc:
        raise ConfigError(f"--modbus-map {family}: {exc}") from exc
    if serial and not pathlib.Path(serial).exists():
        raise ConfigError(f"--modbus-serial {serial}: no such serial device")
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
