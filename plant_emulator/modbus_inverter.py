"""An emulated Modbus inverter: pymodbus server, register map from ``drivers/maps``, motor behind it.

The registers are ``plant_emulator.modbus_registers.InverterContext``'s (the shipped map's
semantics and the application protocol's exceptions).

Addressing: on TCP the unit configured, 0 and 0xFF are this server (the TCP/IP
implementation guide's unit identifier of a directly addressed server); another
unit gets exception 0B, as from a gateway. On RTU the server answers its unit
only, stays silent for any other, and applies a broadcast (address 0) without
answering. The framing (several requests in one TCP segment, resynchronisation
after line noise) is ``plant_emulator.modbus_framing``'s.

Behind the registers: ``InverterModel`` (``plant_emulator.inverter_model``), with
its communication-loss trip. ``serve_tcp`` / ``serve_rtu`` run it on the wall
clock in an asyncio loop; ``InverterServer`` is a handle that serves it from a
thread of its own, with the physics on the wall clock or stepped by its owner
(lock-step).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from collections.abc import Callable
from typing import Any

from pymodbus.datastore import ModbusServerContext

from drivers.maps import modbus_map
from plant_emulator.inverter_model import COMM_LOSS, OVERSPEED, InverterModel
from plant_emulator.modbus_registers import InverterContext

__all__ = [
    "COMM_LOSS",
    "OVERSPEED",
    "InverterContext",
    "InverterModel",
    "InverterServer",
    "default_model",
    "serve_rtu",
    "serve_tcp",
]

log = logging.getLogger(__name__)


def _context(unit: int, context: InverterContext, tcp: bool) -> Any:
    """The server's units: ``unit`` (and on TCP 0 and 0xFF, the directly addressed server's)."""
    make: Any = ModbusServerContext
    units = {unit, 0, 0xFF} if tcp else {unit}
    return make(devices=dict.fromkeys(units, context), single=False)


def _check_unit(unit: int, tcp: bool) -> None:
    """ValueError naming ``unit`` when the server cannot be it (RTU: 1..247; TCP: 0..255)."""
    lo, hi = (0, 255) if tcp else (1, 247)
    if not lo <= unit <= hi:
        line = "TCP" if tcp else "RTU (0 is the broadcast address)"
        raise ValueError(f"Modbus inverter unit {unit!r}: not {lo}..{hi} on {line}")


async def _physics(model: InverterModel, dt: float) -> None:
    """The model on the wall clock, ``dt`` [s] per step; after the loop was held up (a slow
    request), every missed step is made at once, so model time keeps up with the wall clock."""
    loop = asyncio.get_running_loop()
    t_next = loop.time()
    while True:
        now = loop.time()
        while t_next <= now:
            model.step(dt)
            t_next += dt
        await asyncio.sleep(t_next - now)


def _server(model: InverterModel, unit: int, context: InverterContext | None, **where: Any) -> Any:
    """A pymodbus server of the inverter: TCP on ``address`` (host, port), or RTU with ``port``
    a serial device (and ``baudrate`` etc.); ValueError for a unit it cannot be."""
    from plant_emulator.modbus_framing import SpecSerialServer, SpecTcpServer

    tcp = "address" in where
    _check_unit(unit, tcp)
    devices = _context(unit, context or InverterContext(model), tcp)
    if tcp:
        return SpecTcpServer(devices, **where)
    return SpecSerialServer(devices, ignore_missing_devices=True, broadcast_enable=True, **where)


async def _serve(
    server: Any, model: InverterModel, dt: float | None, ready: Callable[[Any], None] | None = None
) -> None:
    """Listen, then serve until cancelled, with the physics on the wall clock every ``dt`` [s]
    (None: none, the owner steps the model). ``ready(server)`` is called once listening;
    OSError when the address or device cannot be opened."""
    try:
        await server.serve_forever(background=True)
    except RuntimeError as exc:  # pymodbus: "Could not start listen, please check address."
        raise OSError(f"Modbus inverter server: {exc}") from None
    task = asyncio.create_task(_physics(model, dt)) if dt is not None else None
    try:
        if ready is not None:
            ready(server)
        await server.serving
    finally:
        if task is not None:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
        await server.shutdown()


async def serve_tcp(
    model: InverterModel,
    *,
    host: str = "127.0.0.1",
    port: int = 5020,
    unit: int = 1,
    dt: float | None = 0.01,
    context: InverterContext | None = None,
) -> None:
    """Serve the inverter on Modbus TCP (127.0.0.1 unless ``host`` names another address) until cancelled.

    Parameters
    ----------
    model : InverterModel
        The inverter.
    host, port, optional
        The address served.
    unit : int, optional
        The Modbus unit id.
    dt : float | None, optional
        [s] the model's step (None: stepped by the caller).
    context : InverterContext | None, optional
        The registers (None: made of ``model``).
    """
    log.info("Modbus TCP inverter (%s) on %s:%d unit %d", model.regmap.name, host, port, unit)
    await _serve(_server(model, unit, context, address=(host, port)), model, dt)


async def serve_rtu(
    model: InverterModel,
    *,
    port: str,
    baudrate: int = 19200,
    unit: int = 1,
    dt: float | None = 0.01,
    context: InverterContext | None = None,
    **serial: Any,
) -> None:
    """Serve the inverter on Modbus RTU over the serial device ``port`` until cancelled.

    Parameters
    ----------
    model : InverterModel
        The inverter.
    port : str
        The serial device.
    baudrate : int, optional
        [bit/s].
    unit : int, optional
        The Modbus unit id.
    dt : float | None, optional
        [s] the model's step (None: stepped by the caller).
    context : InverterContext | None, optional
        The registers (None: made of ``model``).
    **serial : Any
        pyserial's further settings.
    """
    log.info("Modbus RTU inverter (%s) on %s unit %d", model.regmap.name, port, unit)
    await _serve(_server(model, unit, context, port=port, baudrate=baudrate, **serial), model, dt)


class InverterServer:
    """An emulated inverter served from a background thread with its own asyncio loop.

    Modbus TCP on ``host``:``port`` (port 0: a free one; ``port`` tells which once
    started), or RTU on the serial device ``serial`` (one end of a ``PtyLink``, say).
    With ``dt=None`` no physics runs on the wall clock: the owner steps
    ``model.step(dt)`` itself (lock-step); with ``dt`` [s] it runs as ``serve_tcp``.
    ``start()`` returns when the server listens (OSError if it cannot, TimeoutError
    after ``timeout`` [s]); ``stop()`` is idempotent; a context manager starts and stops it.
    ValueError for a ``unit`` the server cannot be (RTU 1..247, TCP 0..255).

    Parameters
    ----------
    model : InverterModel
        The inverter.
    host, port, optional
        Modbus TCP's address (port 0: a free one).
    serial : str | None, optional
        A serial device for Modbus RTU instead (None: TCP).
    baudrate : int, optional
        [bit/s] on ``serial``.
    unit : int, optional
        The Modbus unit id.
    dt : float | None, optional
        [s] the model's step (None: stepped by the caller).
    context : InverterContext | None, optional
        The registers (None: made of ``model``).
    timeout : float, optional
        [s] ``start`` waits for it to listen.
    """

    def __init__(
        self,
        model: InverterModel,
        *,
        host: str = "127.0.0.1",
        port: int = 0,
        serial: str | None = None,
        baudrate: int = 19200,
        unit: int = 1,
        dt: float | None = None,
        context: InverterContext | None = None,
        timeout: float = 10.0,
    ) -> None:
        _check_unit(unit, serial is None)
        self.model = model
        self.context = context or InverterContext(model)
        self._where = (host, port, serial, baudrate, unit)
        self.dt = dt
        self.timeout = timeout
        self._port = 0
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._task: asyncio.Task[None] | None = None
        self._listening = threading.Event()
        self._error: BaseException | None = None

    @property
    def port(self) -> int:
        """The TCP port served (0 before ``start`` and on RTU)."""
        return self._port

    def start(self) -> InverterServer:
        """Serve from a new thread; returns once listening.

        Returns
        -------
        InverterServer
            The server, listening.

        Raises
        ------
        RuntimeError
            If it was started already.
        TimeoutError
            If it is not listening within ``timeout``.
        OSError
            If it could not listen (the address taken, the device missing).
        """
        if self._thread is not None:
            raise RuntimeError("InverterServer.start: already started")
        self._thread = threading.Thread(target=self._run, name="modbus-inverter", daemon=True)
        self._thread.start()
        if not self._listening.wait(self.timeout):
            self.stop()
            raise TimeoutError(f"Modbus inverter server not listening after {self.timeout:g} s")
        if self._error is not None:
            self._thread.join(self.timeout)
            if isinstance(self._error, OSError):
                raise self._error
            raise OSError(f"Modbus inverter server: {self._error}") from self._error
        return self

    def _run(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as exc:  # reported by start(); the thread ends quietly
            self._error = exc
        finally:
            self._listening.set()

    async def _main(self) -> None:
        host, port, serial, baudrate, unit = self._where
        self._loop = asyncio.get_running_loop()
        where = {"address": (host, port)} if serial is None else {"port": serial, "baudrate": baudrate}
        server = _server(self.model, unit, self.context, **where)
        self._task = asyncio.current_task()
        with contextlib.suppress(asyncio.CancelledError):
            await _serve(server, self.model, self.dt, self._on_listening)

    def _on_listening(self, server: Any) -> None:
        sockets = getattr(server.transport, "sockets", None)
        if sockets:
            self._port = int(sockets[0].getsockname()[1])
        where = f"TCP {self._where[0]}:{self._port}" if self._where[2] is None else f"RTU {self._where[2]}"
        log.info("Modbus inverter (%s) on %s unit %d", self.model.regmap.name, where, self._where[4])
        self._listening.set()

    def stop(self) -> None:
        """Stop serving and join the thread (idempotent)."""
        thread, loop, task = self._thread, self._loop, self._task
        if thread is None:
            return
        self.context.released.set()  # a swallowed request holds the server's loop no longer
        if loop is not None and task is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
                loop.call_soon_threadsafe(task.cancel)
        thread.join(self.timeout)

    def __enter__(self) -> InverterServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def default_model(name: str, **overrides: Any) -> InverterModel:
    """An inverter of map ``name`` with parameters overridden by keyword.

    Parameters
    ----------
    name : str
        A register map (``drivers.maps.modbus_maps``).
    **overrides : Any
        ``InverterModel``'s fields.

    Returns
    -------
    InverterModel
        The model.
    """
    return InverterModel(modbus_map(name), **overrides)
