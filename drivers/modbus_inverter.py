"""Host-side Modbus inverter: an ``AxisDriver`` on a pymodbus client (TCP or RTU).

The register map of the family comes from ``drivers/maps``; the unit's registers are read and
written by role in SI units through ``drivers.modbus_unit.ModbusUnit``, which translates the
errors of its answers.

Mode ``speed``: the command is the speed reference [rad/s]; the feedback is
the actual speed [rad/s] and current [A]; the state comes from the status word
as the family's map defines it. Registers are read in as few requests as the
map allows (adjacent registers in one request). A Modbus exception answer
becomes ``ModbusExceptionResponse`` naming the registers' roles, the first
register, the unit and the code with its name; no answer becomes
``CommunicationTimeout``. The client is pymodbus' synchronous one.

The unit is the configured one (default 1, what drives ship with as their
address; ``drivers.modbus_unit.check_unit`` says which are valid on RTU and TCP).
"""

from __future__ import annotations

import itertools
import time
from typing import Any

from pymodbus.exceptions import ModbusException

from drivers.base import AxisDriver, AxisState, Feedback
from drivers.errors import CommunicationError, CommunicationTimeout, ConfigError, DeviceFault, SafetyStop
from drivers.maps import ModbusMap, modbus_map
from drivers.modbus_unit import ModbusUnit, check_unit, contiguous

__all__ = ["ModbusInverterAxis"]

#: what the host loop reads every cycle
_FEEDBACK_ROLES = ("actual_speed", "current", "status_word")


class ModbusInverterAxis(AxisDriver):
    """An inverter of register map ``family`` at ``unit``, over TCP (``host``) or RTU (``serial``).

    Parameters
    ----------
    name : str
        The axis's name.
    family : str
        The register map (``drivers.maps.modbus_maps``).
    unit : int, optional
        The Modbus unit id.
    host, port, optional
        The TCP server (Modbus TCP).
    serial, baudrate, optional
        The serial port and its [bit/s] (Modbus RTU).
    timeout : float, optional
        [s] an answer may take.

    Raises
    ------
    ConfigError
        If the map is unknown or lacks roles, neither ``host`` nor ``serial`` is given, or ``unit`` is out of
        range.
    """

    measures = frozenset({"velocity", "current"})
    sample_name = "answer"

    def __init__(
        self,
        name: str,
        family: str,
        *,
        unit: int = 1,
        host: str | None = None,
        port: int = 502,
        serial: str | None = None,
        baudrate: int = 19200,
        timeout: float = 1.0,
    ) -> None:
        try:
            regmap = modbus_map(family)
        except ValueError as exc:
            raise ConfigError(f"axis {name!r}: {exc}") from None
        missing = [
            r for r in (*_FEEDBACK_ROLES, "control_word", "speed_reference") if r not in regmap.registers
        ]
        if missing:
            raise ConfigError(f"axis {name!r}: map {family!r} lacks the register roles {missing}")
        if not host and not serial:
            raise ConfigError(f"axis {name!r}: a Modbus axis needs host (TCP) or serial (RTU)")
        self.unit = check_unit(name, unit, tcp=bool(host))
        super().__init__(name, "speed")  # checked first: an axis that is not made needs no close
        self.map: ModbusMap = regmap
        self._reached = True  #: False after a setup that could not connect: nothing to disable
        #: the unit: its registers by role, over pymodbus' client
        self.modbus = ModbusUnit(
            regmap, unit=unit, host=host, port=port, serial=serial, baudrate=baudrate, timeout=timeout
        )
        self.client: Any = self.modbus.client
        self._groups = contiguous([self.map[r] for r in _FEEDBACK_ROLES])
        self._count = 0
        self._status: int | None = None  #: the status word of the last feedback

    @property
    def where(self) -> str:
        return self.modbus.where

    def read(self, role: str) -> float:
        """The SI value of the register with ``role``.

        Parameters
        ----------
        role : str
            The register's role in the map (``speed_actual``).

        Returns
        -------
        float
            Its value in SI units.
        """
        return self.modbus.read_group([self.modbus.register(role)])[role]

    def write(self, role: str, value: float) -> None:
        """Write the SI ``value`` to the register with ``role``.

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
            If it answers with an exception or a frame that cannot be decoded.
        """
        self.modbus.write(role, value)

    # --- the axis contract ------------------------------------------------------------------------
    def setup(self) -> None:
        """Connect and read the status word (the unit answers). A unit never reached is not
        disabled on close (one line says it could not connect, not a second that disabling failed).

        Raises
        ------
        CommunicationError
            If the unit cannot be reached.
        """
        try:
            connected = self.client.connect()
        except (ModbusException, OSError) as exc:
            connected, why = False, f": {exc}"
        else:
            why = ""
        self._reached = bool(connected)
        if not connected:
            raise CommunicationError(
                f"Modbus inverter {self.where}: cannot connect{why}: is the inverter on and serving "
                "there? Check the address or serial device and its settings in the [[axis]] table, or, "
                "for an emulated one, start rig emulate --modbus-map NAME (Modbus TCP on 127.0.0.1:5020)"
            )
        self.read("status_word")

    def _state(self, status: int) -> AxisState:
        st = self.map.status
        if "running_value" in st:  # bits 0-1 give the state (Delta)
            running = status & int(st["state_mask"]) == int(st["running_value"])
            return AxisState.ENABLED if running else AxisState.DISABLED
        if status >> int(st["fault_bit"]) & 1:
            return AxisState.FAULT
        return AxisState.ENABLED if status >> int(st["running_bit"]) & 1 else AxisState.DISABLED

    def read_state(self) -> AxisState:
        """The state the status word (and the fault code, where the map has one) says.

        Returns
        -------
        AxisState
            The axis's state.
        """
        state = self._state(int(self.read("status_word")))
        if state is not AxisState.FAULT and "fault_code" in self.map.registers and self.read("fault_code"):
            return AxisState.FAULT
        return state

    def _fault(self) -> DeviceFault:
        code = int(self.read("fault_code")) if "fault_code" in self.map.registers else 0
        return DeviceFault(f"{self.map.name} reports a fault", device=self.where, code=code)

    def enable(self, *, timeout: float = 1.0) -> None:
        """Speed reference 0, then the family's run command; waits until the status word says running.

        Parameters
        ----------
        timeout : float, optional
            [s] to wait for the status word to say running.

        Raises
        ------
        DeviceFault
            If the status word reports a fault.
        CommunicationTimeout
            If it is not running after ``timeout``.
        """
        if self.read_state() is AxisState.FAULT:
            raise self._fault()
        self.write("speed_reference", 0.0)
        self.write("control_word", self.map.control["run"])
        deadline = time.monotonic() + timeout
        for _ in itertools.count():
            if self.read_state() is AxisState.ENABLED:
                return
            if time.monotonic() > deadline:
                raise CommunicationTimeout(f"{self.where}: not running {timeout:g} s after the run command")

    def command(self, value: float | complex) -> None:
        """The speed reference [rad/s].

        Parameters
        ----------
        value : float | complex
            The speed reference [rad/s].
        """
        self.write("speed_reference", float(value.real if isinstance(value, complex) else value))

    def disable(self) -> None:
        """The family's stop command (a ramp stop); none to a unit setup could not connect to."""
        if self._reached:
            self.write("control_word", self.map.control["stop"])

    def quick_stop(self) -> None:
        """The family's quick (emergency ramp) stop where the map has one, else its stop."""
        self.write("control_word", self.map.control.get("quick_stop", self.map.control["stop"]))

    def reset_fault(self) -> None:
        """The family's fault reset (its reset register, else stop then reset on the control word)."""
        ctl = self.map.control
        if "reset_register_role" in ctl:
            self.write(ctl["reset_register_role"], ctl["reset"])
        else:
            self.write("control_word", ctl["stop"])
            self.write("control_word", ctl["reset"])

    def feedback(self) -> Feedback:
        """Actual speed [rad/s] and current [A], read now; the status word is kept for ``supervise``.

        Returns
        -------
        Feedback
            Speed [rad/s] and current [A].
        """
        values: dict[str, float] = {}
        for group in self._groups:
            values.update(self.modbus.read_group(group))
        self._status = int(values["status_word"])
        self._count += 1
        return Feedback(velocity=values["actual_speed"], current=values["current"], stamp=float(self._count))

    def supervise(self, now: float) -> None:
        """A status word that reports a fault, or that the drive stopped running, stops the loop.

        Parameters
        ----------
        now : float
            [s] ``time.monotonic()`` (unused: the status word read by ``feedback`` decides).

        Raises
        ------
        DeviceFault
            If the status word reports a fault.
        SafetyStop
            If the inverter stopped running.
        """
        if self._status is None:
            return
        state = self._state(self._status)
        if state is AxisState.FAULT:
            raise self._fault()
        if state is not AxisState.ENABLED:
            raise SafetyStop(f"{self.where}: the inverter stopped running (status word 0x{self._status:04X})")

    def _release(self) -> None:
        self.client.close()
