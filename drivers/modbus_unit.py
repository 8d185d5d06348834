"""One Modbus unit's registers, by role in SI units, over pymodbus' synchronous client (TCP or RTU).

The roles and their scaling are the register map of the unit's family (``drivers.maps``).
Registers of adjacent addresses are read in one request (``contiguous``); a write is checked
against its echo. Every answer is checked and its errors translated here, once: an exception
answer becomes ``ModbusExceptionResponse`` naming the registers' roles, the first register, the
unit and the code; no answer ``CommunicationTimeout``; an answer of another function, of another
number of registers or one pymodbus cannot decode ``CommunicationError``.

The unit is the configured one (``check_unit``). On RTU it is 1..247: 0 is the broadcast
address, which no server answers. On TCP it is 0..255: a device directly on TCP/IP is normally
addressed as 0xFF (or 0), one behind a gateway by its serial address; many drives accept their
own address only, so the drivers' default stays 1.
"""

from __future__ import annotations

from typing import Any

from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ModbusException
from pymodbus.framer import FramerType

from drivers.errors import CommunicationError, CommunicationTimeout, ConfigError, ModbusExceptionResponse
from drivers.maps import ModbusMap, Register

__all__ = ["ModbusUnit", "check_unit", "contiguous"]

_READ, _WRITE = 3, 6  #: the function codes used: read holding registers, write single register


def check_unit(name: str, unit: int, *, tcp: bool) -> int:
    """``unit`` if it is one on its transport: RTU 1..247 (0 is the broadcast address, which no
    server answers); TCP 0..255 (0xFF or 0 address a server directly on TCP/IP, 1..247 one behind
    a gateway or a device that wants its own address).

    Parameters
    ----------
    name : str
        The axis, named in the error.
    unit : int
        The Modbus unit id.
    tcp : bool
        Modbus TCP (else RTU).

    Returns
    -------
    int
        ``unit``.

    Raises
    ------
    ConfigError
        If it is out of range.
    """
    lo, hi = (0, 255) if tcp else (1, 247)
    if not lo <= unit <= hi:
        line = "TCP" if tcp else "RTU (0 is the broadcast address: no server answers it)"
        raise ConfigError(f"axis {name!r}: Modbus unit {unit!r} is not {lo}..{hi} on {line}")
    return unit


def contiguous(regs: list[Register]) -> list[list[Register]]:
    """Registers grouped into runs of adjacent addresses (one request each).

    Parameters
    ----------
    regs : list[Register]
        The registers.

    Returns
    -------
    list[list[Register]]
        The runs, by address.
    """
    regs = sorted(regs, key=lambda r: r.address)
    groups: list[list[Register]] = []
    for reg in regs:
        if groups and reg.address == groups[-1][-1].address + 1:
            groups[-1].append(reg)
        else:
            groups.append([reg])
    return groups


class ModbusUnit:
    """Unit ``unit`` (checked by ``check_unit``) of register map ``regmap``, over TCP (``host``)
    or RTU (``serial``); see the module docstring.

    Parameters
    ----------
    regmap : ModbusMap
        The family's register map.
    unit : int
        The Modbus unit id.
    host : str | None
        The TCP server (Modbus TCP), or None.
    port : int
        Its port.
    serial : str | None
        The serial port (Modbus RTU), where ``host`` is None.
    baudrate : int
        [bit/s] on ``serial``.
    timeout : float
        [s] an answer may take.
    """

    def __init__(
        self,
        regmap: ModbusMap,
        *,
        unit: int,
        host: str | None,
        port: int,
        serial: str | None,
        baudrate: int,
        timeout: float,
    ) -> None:
        self.map = regmap
        self.unit = unit
        self.client: Any  #: pymodbus' synchronous client
        if host:
            self.client = ModbusTcpClient(host, port=port, timeout=timeout, retries=1)
            self.where = f"unit {unit} at {host}:{port}"  #: the unit and its address, in every error
        else:
            assert serial  # checked by the driver
            self.client = ModbusSerialClient(
                serial, framer=FramerType.RTU, baudrate=baudrate, timeout=timeout, retries=1
            )
            self.where = f"unit {unit} on {serial}"

    def _exception(self, rr: Any, what: str, register: int) -> ModbusExceptionResponse:
        """The toolkit error for the exception answer ``rr`` to ``what`` (``reading status_word``)."""
        raw = getattr(rr, "exception_code", 0)
        code = raw if isinstance(raw, int) else 0
        return ModbusExceptionResponse(
            f"{self.map.name} at {self.where}: exception answer {what}",
            code=code,
            unit=self.unit,
            register=register,
        )

    def _undecoded(self, exc: Exception, what: str, register: int) -> CommunicationError:
        """The toolkit error for an answer pymodbus failed on with ``exc`` (not its own kind)."""
        return CommunicationError(
            f"{self.map.name} at {self.where}: the answer {what} (register {register}) is not one "
            f"pymodbus decodes ({type(exc).__name__}: {exc})"
        )

    def _check(self, rr: Any, what: str, register: int, count: int = 1, function: int = _READ) -> list[int]:
        """The ``count`` registers of answer ``rr`` to a request of ``function`` (a read of
        holding registers; a write's echo), or the toolkit's error naming what was asked: an
        exception answer, an answer of another function, another number of registers."""
        if rr is None:
            raise CommunicationTimeout(f"{self.where}: no answer {what} (register {register})")
        if rr.isError():
            raise self._exception(rr, what, register)
        code = getattr(rr, "function_code", function)
        if code != function:
            raise CommunicationError(
                f"{self.map.name} at {self.where}: the answer {what} (register {register}) is one of "
                f"function {code!r}, not {function}"
            )
        registers = getattr(rr, "registers", None)
        if (
            not isinstance(registers, list)
            or len(registers) != count
            or not all(isinstance(v, int) and 0 <= v <= 0xFFFF for v in registers)
        ):
            shown = repr(registers)[:60]
            raise CommunicationError(
                f"{self.map.name} at {self.where}: the answer {what} (register {register}) does not hold "
                f"{count} 16-bit register value(s): {shown}"
            )
        return registers

    def read_group(self, group: list[Register]) -> dict[str, float]:
        """The SI values of a run of adjacent registers (``contiguous``), in one request.

        Parameters
        ----------
        group : list[Register]
            The registers, by address.

        Returns
        -------
        dict[str, float]
            Role -> its value in SI units.

        Raises
        ------
        CommunicationTimeout
            If the unit does not answer.
        CommunicationError
            If it answers with an exception or a frame that cannot be decoded.
        """
        start = group[0].address
        what = "reading " + ", ".join(r.role for r in group)
        try:
            rr = self.client.read_holding_registers(start, count=len(group), device_id=self.unit)
        except ModbusException as exc:  # none, or none pymodbus could decode
            span = f"register {start}" if len(group) == 1 else f"registers {start}-{group[-1].address}"
            raise CommunicationTimeout(f"{self.where}: no answer {what} ({span})") from exc
        except Exception as exc:  # pymodbus decodes an answer blindly: struct.error, IndexError ...
            raise self._undecoded(exc, what, start) from exc
        raw = self._check(rr, what, start, len(group))
        return {reg.role: reg.to_si(v) for reg, v in zip(group, raw)}

    def register(self, role: str) -> Register:
        """The register with ``role``.

        Parameters
        ----------
        role : str
            Its role in the map.

        Returns
        -------
        Register
            The register.

        Raises
        ------
        ConfigError
            If the map has no such role.
        """
        try:
            return self.map[role]
        except KeyError as exc:
            raise ConfigError(f"{self.where}: {exc.args[0]}") from None

    def write(self, role: str, value: float) -> None:
        """Write the SI ``value`` to the register with ``role``, checked against the echo.

        Parameters
        ----------
        role : str
            The register's role in the map.
        value : float
            In SI units.

        Raises
        ------
        ConfigError
            If the value does not fit the register.
        CommunicationTimeout
            If the unit does not answer.
        CommunicationError
            If it answers with an exception, a frame that cannot be decoded, or not the echo.
        """
        reg = self.register(role)
        try:
            raw = reg.to_raw(value)
        except ValueError as exc:
            raise ConfigError(f"{self.where}: {exc}") from None
        what = f"writing {role}"
        try:
            rr = self.client.write_register(reg.address, raw, device_id=self.unit)
        except ModbusException as exc:
            raise CommunicationTimeout(f"{self.where}: no answer {what} (register {reg.address})") from exc
        except Exception as exc:  # as in read_group
            raise self._undecoded(exc, what, reg.address) from exc
        echo = self._check(rr, what, reg.address, function=_WRITE)
        if echo != [raw] or getattr(rr, "address", reg.address) != reg.address:
            raise CommunicationError(
                f"{self.map.name} at {self.where}: the answer {what} (register {reg.address}) is not "
                f"the echo of {raw} to register {reg.address}: {echo} to {getattr(rr, 'address', None)}"
            )
