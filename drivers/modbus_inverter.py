"""Host-side Modbus inverter driver (pymodbus client, TCP or RTU), register map from ``drivers/maps``.

SI in and out: speed in rad/s, current in A. A Modbus exception answer
becomes ``ModbusExceptionResponse`` with its code, unit and register; no
answer becomes ``CommunicationTimeout``. The client is pymodbus' synchronous
one, so the host loop calls it directly.
"""

from __future__ import annotations

from typing import Any

from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ModbusException
from pymodbus.framer import FramerType

from drivers.errors import CommunicationError, CommunicationTimeout, ModbusExceptionResponse
from drivers.maps import ModbusMap, modbus_map

__all__ = ["ModbusInverter"]


class ModbusInverter:
    """An inverter of map ``family`` at ``unit``, over TCP (``host``) or RTU (``port``)."""

    def __init__(
        self,
        family: str,
        *,
        unit: int = 1,
        host: str | None = None,
        tcp_port: int = 502,
        port: str | None = None,
        baudrate: int = 19200,
        timeout: float = 1.0,
    ) -> None:
        self.map: ModbusMap = modbus_map(family)
        self.unit = unit
        self.client: Any
        if host is not None:
            self.client = ModbusTcpClient(host, port=tcp_port, timeout=timeout, retries=1)
            self.where = f"{host}:{tcp_port}"
        elif port is not None:
            self.client = ModbusSerialClient(
                port, framer=FramerType.RTU, baudrate=baudrate, timeout=timeout, retries=1
            )
            self.where = port
        else:
            raise ValueError("ModbusInverter needs host (TCP) or port (RTU)")

    def connect(self) -> None:
        if not self.client.connect():
            raise CommunicationError(f"Modbus inverter at {self.where}: cannot connect")

    def close(self) -> None:
        self.client.close()

    def _check(self, rr: Any, register: int) -> Any:
        if rr is None:
            raise CommunicationTimeout(f"{self.where}: no answer for register {register}")
        if rr.isError():
            code = getattr(rr, "exception_code", 0)
            raise ModbusExceptionResponse(
                f"{self.map.name} at {self.where}", code=code, unit=self.unit, register=register
            )
        return rr

    def read(self, role: str) -> float:
        """The SI value of the register with ``role``."""
        reg = self.map[role]
        try:
            rr = self.client.read_holding_registers(reg.address, count=1, device_id=self.unit)
        except ModbusException as exc:
            raise CommunicationTimeout(
                f"{self.where}: no answer reading {role} (register {reg.address})"
            ) from exc
        registers = getattr(self._check(rr, reg.address), "registers", None)
        if not registers or not isinstance(registers[0], int) or not 0 <= registers[0] <= 0xFFFF:
            raise CommunicationError(
                f"{self.map.name} at {self.where}: the answer for {role} (register {reg.address}) "
                f"holds no 16-bit register value: {registers!r}"
            )
        return reg.to_si(registers[0])

    def write(self, role: str, value: float) -> None:
        """Write the SI ``value`` to the register with ``role``."""
        reg = self.map[role]
        raw = reg.to_raw(value)
        try:
            rr = self.client.write_register(reg.address, raw, device_id=self.unit)
        except ModbusException as exc:
            raise CommunicationTimeout(
                f"{self.where}: no answer writing {role} (register {reg.address})"
            ) from exc
        self._check(rr, reg.address)

    def run(self, speed: float) -> None:
        """Speed reference [rad/s], then the run command of the family."""
        self.write("speed_reference", speed)
        self.write("control_word", self.map.control["run"])

    def stop(self) -> None:
        self.write("control_word", self.map.control["stop"])

    def reset_fault(self) -> None:
        ctl = self.map.control
        if "reset_register_role" in ctl:
            self.write(ctl["reset_register_role"], ctl["reset"])
        else:
            self.write("control_word", ctl["stop"])
            self.write("control_word", ctl["reset"])
