"""An emulated Modbus inverter: pymodbus server, register map from ``drivers/maps``, motor behind it.

The register semantics follow the shipped map (``abb-drives-profile`` or
``delta-vfd-b``): control word (run, stop, fault reset), speed reference,
status word, actual speed, current and fault code. Reads and writes go
through ``InverterContext``, in the order of the application protocol's
request diagrams: a function other than the holding/input registers' gets
exception 01, a read of a quantity not 1..125 03, an unknown register or a
write to a read-only one 02 (illegal data address), a reference out of the
map's range 03 (illegal data value).

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

from pymodbus.constants import ExcCodes
from pymodbus.datastore import ModbusServerContext
from pymodbus.datastore.context import ModbusBaseDeviceContext

from drivers.maps import modbus_map
from plant_emulator.inverter_model import COMM_LOSS, OVERSPEED, InverterModel

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
MAX_READ = 125  #: registers in one read request (application protocol 6.3, 6.4)


class InverterContext(ModbusBaseDeviceContext):
    """Holding registers of ``model.regmap`` with the family's control semantics.

    Parameters
    ----------
    model : InverterModel
        The inverter.
    """

    def __init__(self, model: InverterModel) -> None:
        self.model = model
        self.map = model.regmap
        self.by_address = self.map.by_address()
        self.control_word = int(self.map.control["stop"])
        self.writes = 0
        self.fault_mode: str | None = None  #: fault injection: None, "timeout" or "exception"
        self.timeout_sleep = 1.5  #: [s] how long a swallowed request blocks at most
        #: set: a swallowed request blocks no longer (``InverterServer.stop`` sets it)
        self.released = threading.Event()

    def reset(self) -> None:
        """The control word back to the family's stop."""
        self.control_word = int(self.map.control["stop"])

    def _read(self, role: str) -> int:
        m = self.model
        if role == "control_word":
            return int(self.control_word)
        if role == "status_word":
            return self._status()
        if role == "fault_code":
            return int(m.fault)
        value = {
            "speed_reference": m.reference,
            "frequency_command": m.reference,
            "actual_speed": m.speed,
            "current": m.current,
            "torque_reference": 0.0,
            "actual_torque": 100.0 * m.load(m.t) / m.rated_torque,
            "dc_bus_voltage": 540.0,
            "fault_control": 0.0,
        }[role]
        reg = self.map[role]
        try:
            return reg.to_raw(abs(value) if not reg.signed else value)
        except ValueError:
            return 0xFFFF if not reg.signed else 0x7FFF

    def _status(self) -> int:
        m = self.model
        st = {k: int(v) for k, v in self.map.status.items()}
        if "running_value" in st:  # Delta: bits 0-1 state
            return int(st["running_value"]) if m.running else 0
        word = (1 << int(st["remote_bit"])) | 0x30  # OFF2, OFF3 inactive
        if m.fault:
            return word | (1 << st["fault_bit"])
        word |= 1 << st["ready_bit"]
        if m.running:
            word |= (1 << st["running_bit"]) | 0x02
            if abs(m.speed - m.reference) < 0.01 * max(1.0, abs(m.reference)):
                word |= 1 << st["at_setpoint_bit"]
        return word

    def _fault_injected(self) -> ExcCodes | None:
        """Fault injection: ``timeout`` swallows the request (no answer for ``timeout_sleep`` or
        until ``released``, and the drive sees nothing), ``exception`` answers every request with
        exception 04 (device failure)."""
        if self.fault_mode == "timeout":
            self.released.wait(self.timeout_sleep)
            return ExcCodes.DEVICE_FAILURE  # too late: the client has given up
        self.model.last_request = self.model.t
        if self.fault_mode == "exception":
            return ExcCodes.DEVICE_FAILURE
        return None

    def getValues(self, func_code: int, address: int, count: int = 1) -> list[int] | ExcCodes:
        """pymodbus' read of ``count`` registers from ``address`` (function ``func_code``).

        Parameters
        ----------
        func_code : int
            The Modbus function code.
        address : int
            The first register.
        count : int, optional
            How many.

        Returns
        -------
        list[int] | ExcCodes
            The registers' values, or the exception code to answer.
        """
        injected = self._fault_injected()
        if injected is not None:
            return injected
        if func_code not in (3, 4, 6, 16, 22, 23):  # holding/input registers (6, 16: read-back after write)
            return ExcCodes.ILLEGAL_FUNCTION
        if not 1 <= count <= MAX_READ:
            return ExcCodes.ILLEGAL_VALUE
        out = []
        for a in range(address, address + count):
            reg = self.by_address.get(a)
            if reg is None:
                return ExcCodes.ILLEGAL_ADDRESS
            out.append(self._read(reg.role))
        return out

    def setValues(self, func_code: int, address: int, values: list[int] | list[bool]) -> ExcCodes | None:
        """pymodbus' write of ``values`` from ``address`` (function ``func_code``).

        Parameters
        ----------
        func_code : int
            The Modbus function code.
        address : int
            The first register.
        values : list[int] | list[bool]
            The values written.

        Returns
        -------
        ExcCodes | None
            The exception code to answer; None: written.
        """
        injected = self._fault_injected()
        if injected is not None:
            return injected
        if func_code not in (6, 16):
            return ExcCodes.ILLEGAL_FUNCTION
        regs = [self.by_address.get(a) for a in range(address, address + len(values))]
        if any(r is None or r.access != "rw" for r in regs):
            return ExcCodes.ILLEGAL_ADDRESS
        for reg, raw in zip(regs, values):
            assert reg is not None
            err = self._write(reg.role, int(raw))
            if err is not None:
                return err
        self.writes += 1
        return None

    def _write(self, role: str, raw: int) -> ExcCodes | None:
        m, ctl = self.model, self.map.control
        if role == "speed_reference":
            value = self.map[role].to_si(raw)
            if abs(value) > m.max_speed:
                return ExcCodes.ILLEGAL_VALUE
            m.reference = value
        elif role == "control_word":
            reset_bit = ctl.get("reset_bit")
            if reset_bit is not None and raw & (1 << reset_bit) and not self.control_word & (1 << reset_bit):
                m.fault = 0
            self.control_word = raw
            mask = int(ctl["run_mask"])
            m.running = (raw & mask) == (int(ctl["run"]) & mask) and not m.fault
        elif role == "fault_control":
            if raw & 0x2:
                m.fault = 0
            if raw & 0x1:
                m.fault = 0x0002  # external fault
                m.running = False
        return None


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
