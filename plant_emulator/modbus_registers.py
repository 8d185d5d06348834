"""The emulated Modbus inverter's registers (``plant_emulator.modbus_inverter``) as pymodbus reads
and writes them.

The register semantics follow the shipped map (``abb-drives-profile`` or ``delta-vfd-b``): control
word (run, stop, fault reset), speed reference, status word, actual speed, current and fault code.
Reads and writes go through ``InverterContext``, in the order of the application protocol's
request diagrams: a function other than the holding/input registers' gets exception 01, a read of
a quantity not 1..125 03, an unknown register or a write to a read-only one 02 (illegal data
address), a reference out of the map's range 03 (illegal data value).
"""

from __future__ import annotations

import threading

from pymodbus.constants import ExcCodes
from pymodbus.datastore.context import ModbusBaseDeviceContext

from plant_emulator.inverter_model import InverterModel

__all__ = ["MAX_READ", "InverterContext"]

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
