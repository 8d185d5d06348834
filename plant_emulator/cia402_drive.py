"""An emulated CiA 402 servo drive / converter on the bus, with an ``Axis`` behind it.

Per SYNC (period ``period`` [s]): the physics advances one period with the
commands in force (the drive's ``Shaft``, once for all the nodes on it), the
drive checks its limits, latches the feedback into the object dictionary and
sends its synchronous TPDOs. A drive whose power stage is off gives no
commands and lets its axis coast; an NMT reset lets go of the axis (the shaft
keeps its motion). Command timing is the two
delay cases of the dq-current paper: a synchronous RPDO (type 0-240) is
applied at the next SYNC (one period of delay: s-PWM-start); an event RPDO
(type 254/255) is applied ``0x2001`` microseconds after receipt (a fraction
of a period: s-PWM-middle with T_s/2). SDO writes of a target act at the next SYNC.

Units on the wire (device units, converted here and in the driver from the
same EDS objects): position [increments, 0x608F], velocity [increments/s],
torque and current [per mille of 0x6076 / 0x6075], voltage [mV], dq current
[mA], angle [urad].

Faults (EMCY with 0x603F and 0x1001): over-current 0x2310 (|i| above 0x6073),
over-speed 0x8400 (|omega| above 0x6080 rpm), following error 0x8611 (CSP,
|error| above 0x6065 increments). The fault reaction (0x605E) and quick stop
(0x605A) brake with the speed loop where the axis has one, or coast (option 0).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import canopen
from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import CIA402_EDS, cia
from drivers.maps.cia import (
    MODE_BITS,
    SW_FOLLOWING_ERROR,
    SW_FOLLOWS_COMMAND,
    SW_REMOTE,
    TARGET_OF_MODE,
    EmcyCode,
    ErrorRegister,
    Mode,
    PowerState,
    QuickStopOption,
    SdoAbortCode,
)
from plant_emulator.axes import Axis
from plant_emulator.canopen_node import OPERATIONAL, EmulatedNode
from plant_emulator.cia402_state import PowerStateMachine
from plant_emulator.shaft import Shaft, Timed

__all__ = ["FAULT_CODES", "EmulatedDrive", "Ratings"]

log = logging.getLogger(__name__)

FAULT_CODES: dict[int, str] = {
    EmcyCode.OVER_CURRENT: "over-current",
    EmcyCode.OVER_SPEED: "over-speed",
    EmcyCode.FOLLOWING_ERROR: "following error",
}
#: objects holding a command: an SDO write of one takes effect at the next SYNC
_TARGETS = {index for index, _ in TARGET_OF_MODE.values()} | {cia.DQ_VOLTAGE}
_SIGNED = (cia.MODES_OF_OPERATION, cia.QUICK_STOP_OPTION, cia.FAULT_REACTION_OPTION)
_CYCLIC = (Mode.CSP, Mode.CSV, Mode.CST)
_QUICK_STOP_OPTIONS = frozenset(int(o) for o in QuickStopOption)
S = PowerState


@dataclass(frozen=True)
class Ratings:
    """A drive's rated and maximum values (written to its object dictionary by ``EmulatedDrive.rate``)."""

    rated_current: float  #: 0x6075 [A]
    rated_torque: float  #: 0x6076 [N m]
    max_current_permille: int  #: 0x6073 [per mille of the rated current]
    max_speed_rpm: int  #: 0x6080 [rpm]

    def as_stored(self) -> Ratings:
        """These ratings as the object dictionary holds them (whole mA and mN m)."""
        return replace(
            self,
            rated_current=round(self.rated_current * 1000) / 1000,
            rated_torque=round(self.rated_torque * 1000) / 1000,
        )


class EmulatedDrive(EmulatedNode):
    """A CiA 402 drive node with ``axis`` behind it; see the module docstring.

    ``shaft``: the plant the axis is part of (``plant_emulator.shaft``), shared with the
    other nodes on it; None gives the drive a shaft of its own.
    """

    def __init__(
        self,
        node_id: int,
        network: canopen.Network,
        axis: Axis,
        *,
        period: float,
        eds: str = CIA402_EDS,
        shaft: Shaft | None = None,
    ) -> None:
        shaft = shaft or Shaft(axis, period=period)
        if axis not in shaft.axes:
            raise ValueError("the drive's axis must be one of its shaft's axes")
        if period != shaft.period:
            raise ValueError(f"the drive's period {period!r} s is not its shaft's, {shaft.period!r} s")
        self.axis = axis
        self.shaft = shaft
        self.period = period
        self.sm = PowerStateMachine()
        self._pending: list[Timed] = []
        self._t_sync = 0.0
        self.glitch_counts = 0  #: fault injection: added to the latched position [increments]
        self._sdo_target = False
        self._in_rpdo = False
        self.fault_code = 0
        self._pending_cw: int | None = None
        super().__init__(node_id, eds, network)
        self.write(cia.SUPPORTED_MODES, 0, sum(MODE_BITS[m] for m in axis.modes))
        self.node.add_write_callback(self._on_drive_write)
        shaft.attach(self)

    @property
    def lockstep(self) -> bool:
        """True: an event RPDO counts as received at its SYNC and time is the SYNC count (lock-step
        across processes, where a frame's real arrival time is scheduling noise); False: arrival
        times count (real time). A property of the shaft, so the nodes on it agree."""
        return self.shaft.lockstep

    @lockstep.setter
    def lockstep(self, value: bool) -> None:
        self.shaft.lockstep = value

    def rate(self, ratings: Ratings, *, counts_per_rev: int) -> None:
        """Write the ratings and the position resolution [increments/rev] (device side, SI in)."""
        self.write(cia.RATED_CURRENT, 0, round(ratings.rated_current * 1000))  # mA
        self.write(cia.RATED_TORQUE, 0, round(ratings.rated_torque * 1000))  # mN m
        self.write(cia.MAX_CURRENT, 0, ratings.max_current_permille)
        self.write(cia.MAX_MOTOR_SPEED, 0, ratings.max_speed_rpm)
        self.write(cia.POSITION_ENCODER_RESOLUTION, 1, counts_per_rev)

    # --- units ----------------------------------------------------------------
    @property
    def counts_per_rad(self) -> float:
        res = cia.POSITION_ENCODER_RESOLUTION
        return self._u(res, 1) / (self._u(res, 2) * 2.0 * math.pi)

    def _rated_torque(self) -> float:
        return self._u(cia.RATED_TORQUE, 0) / 1000.0  # mN m -> N m

    def _rated_current(self) -> float:
        return self._u(cia.RATED_CURRENT, 0) / 1000.0  # mA -> A

    def _command(self, mode: int) -> complex:
        """The present target of ``mode`` from the object dictionary, in SI."""
        if mode == Mode.VOLTAGE:
            return complex(self.read(cia.TARGET_VOLTAGE) / 1000.0)
        if mode == Mode.DQ_VOLTAGE:
            return complex(self.read(cia.DQ_VOLTAGE, 1), self.read(cia.DQ_VOLTAGE, 2)) / 1000.0
        if mode == Mode.CST:
            return complex(self.read(cia.TARGET_TORQUE) / 1000.0 * self._rated_torque())
        if mode in (Mode.CSV, Mode.PROFILE_VELOCITY):
            return complex(self.read(cia.TARGET_VELOCITY) / self.counts_per_rad)
        if mode == Mode.CSP:
            return complex(self.read(cia.TARGET_POSITION) / self.counts_per_rad)
        return 0j

    # --- object writes -----------------------------------------------------
    def _on_drive_write(self, index: int, subindex: int, od: object, data: bytes) -> None:
        value = int.from_bytes(data, "little", signed=index in _SIGNED)
        if index == cia.MODES_OF_OPERATION:
            if value not in self.axis.modes:
                raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
            self.write(cia.MODES_DISPLAY, 0, value)
        elif index == cia.QUICK_STOP_OPTION:
            if value not in _QUICK_STOP_OPTIONS:
                raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
            self.sm.quick_stop_option = value
        elif index == cia.CONTROLWORD:
            self._pending_cw = value
            if not self._in_rpdo:
                self._apply_controlword(value)
        elif index in _TARGETS and not self._in_rpdo:
            self._sdo_target = True

    def _unpack(self, pdo, data):  # type: ignore[no-untyped-def]
        self._in_rpdo = True
        try:
            super()._unpack(pdo, data)
        finally:
            self._in_rpdo = False

    def _apply_controlword(self, cw: int) -> None:
        before = self.sm.state
        after = self.sm.command(cw)
        if after is not before:
            log.info("node %d: %s -> %s (controlword 0x%04X)", self.node_id, before.value, after.value, cw)
            if before is S.FAULT:
                self.fault_code = 0
                self.write(cia.ERROR_CODE, 0, EmcyCode.NO_ERROR)
                self.write(cia.ERROR_REGISTER, 0, 0)
                if self.nmt_state == OPERATIONAL:
                    self.node.emcy.reset()
            if after is S.OPERATION_ENABLED:
                mode = self.read(cia.MODES_DISPLAY)
                if mode in self.axis.modes:
                    self.axis.set_command(mode, self._hold_command(mode))
                else:  # no mode selected: enabled, but no torque
                    self.axis.coast()
        self._latch_status()

    def _hold_command(self, mode: int) -> complex:
        """On enable: hold the present position/speed rather than jump to a stale target."""
        if mode == Mode.CSP:
            return complex(self.axis.position)
        return 0j

    def on_rpdo(self, number: int, *, synchronous: bool) -> None:
        if self._pending_cw is not None:
            cw, self._pending_cw = self._pending_cw, None
            self._apply_controlword(cw)
        if self.sm.state is not S.OPERATION_ENABLED:
            return
        mode = self.read(cia.MODES_DISPLAY)
        if mode not in self.axis.modes:
            return
        value = self._command(mode)
        if synchronous:
            self._pending.append((0.0, self.axis, mode, value, True))
        else:
            latency = self._u(cia.COMMAND_LATENCY, 0) * 1e-6  # us -> s
            arrival = 0.0 if self.lockstep else max(self.rx_time - self._t_sync, 0.0)
            offset = min(arrival + latency, self.period)
            self._pending.append((offset, self.axis, mode, value, False))

    def on_reset(self, *, application: bool) -> None:
        """Power-on or NMT reset node: the drive lets go of its axis; the shaft keeps turning."""
        self.axis.release()
        self.sm = PowerStateMachine()
        self.sm.power_on()
        self.sm.quick_stop_option = QuickStopOption.QUICK_STOP_RAMP
        self._pending.clear()
        self.fault_code = 0
        self._latch_status()

    # --- the cycle ----------------------------------------------------------
    def take_timeline(self) -> list[Timed]:
        """The commands of the period just ended, for the shaft; none (and the axis coasts)
        when the power stage is off."""
        pending, self._pending = self._pending, []
        if not self.sm.power_stage_on:
            self.axis.coast()
            return []
        return pending

    def _stop_reaction(self) -> None:
        st = self.sm.state
        if st not in (S.QUICK_STOP_ACTIVE, S.FAULT_REACTION_ACTIVE):
            return
        option = (
            self.sm.quick_stop_option if st is S.QUICK_STOP_ACTIVE else self.read(cia.FAULT_REACTION_OPTION)
        )
        if option == QuickStopOption.DISABLE_DRIVE or Mode.CSV not in self.axis.modes:
            self.axis.coast()
            self.sm.reaction_done()
            return
        self.axis.set_command(Mode.CSV, 0.0)
        if abs(self.axis.velocity) < 1e-2:
            self.sm.reaction_done()
            if self.sm.state in (S.FAULT, S.SWITCH_ON_DISABLED):
                self.axis.coast()

    def _check_limits(self) -> None:
        if self.sm.state in (S.FAULT, S.FAULT_REACTION_ACTIVE):
            return
        code = EmcyCode.NO_ERROR
        i_max = self.read(cia.MAX_CURRENT) / 1000.0 * self._rated_current()
        w_max = self._u(cia.MAX_MOTOR_SPEED, 0) * 2.0 * math.pi / 60.0  # rpm -> rad/s
        if abs(self.axis.current) > i_max:
            code = EmcyCode.OVER_CURRENT
        elif Mode.DQ_VOLTAGE not in self.axis.modes and abs(self.axis.velocity) > w_max:
            code = EmcyCode.OVER_SPEED
        elif self.read(cia.MODES_DISPLAY) == Mode.CSP and self.sm.state is S.OPERATION_ENABLED:
            error = self.read(cia.TARGET_POSITION) - self.read(cia.POSITION_ACTUAL)
            if abs(error) > self._u(cia.FOLLOWING_ERROR_WINDOW, 0):
                code = EmcyCode.FOLLOWING_ERROR
        if code:
            self.raise_fault(code)

    def raise_fault(self, code: int) -> None:
        """A device fault: state machine transition 13, 0x603F, 0x1001 and EMCY."""
        log.warning("node %d: fault 0x%04X %s", self.node_id, code, FAULT_CODES.get(code, ""))
        self.fault_code = code
        self.sm.fault()
        self.write(cia.ERROR_CODE, 0, code)
        register = ErrorRegister.GENERIC
        if code >> 12 == 0x2:  # 0x2xxx: current
            register |= ErrorRegister.CURRENT
        elif code >> 12 == 0x8:  # 0x8xxx: monitoring (the profile's control loops)
            register |= ErrorRegister.DEVICE_PROFILE
        self.emcy(code, register)

    def on_sync_latch(self, timestamp: float) -> None:
        self.shaft.sync(self, timestamp)  # the shaft at this SYNC, advanced once for all its nodes
        self._t_sync = timestamp
        mode = self.read(cia.MODES_DISPLAY)
        if self._sdo_target and self.sm.state is S.OPERATION_ENABLED and mode in self.axis.modes:
            self._pending.append((0.0, self.axis, mode, self._command(mode), False))
        self._sdo_target = False
        self._check_limits()
        self._stop_reaction()
        self._latch()

    def _latch_status(self) -> None:
        word = self.sm.statusword() | SW_REMOTE
        if self.sm.state is S.OPERATION_ENABLED and self.read(cia.MODES_DISPLAY) in _CYCLIC:
            word |= SW_FOLLOWS_COMMAND
        if self.fault_code == EmcyCode.FOLLOWING_ERROR:
            word |= SW_FOLLOWING_ERROR
        self.write(cia.STATUSWORD, 0, word)

    def _latch(self) -> None:
        ax = self.axis
        cpr = self.counts_per_rad
        pos = math.floor(ax.position * cpr) + self.glitch_counts
        self.write(cia.POSITION_ACTUAL, 0, max(-(2**31), min(2**31 - 1, pos)))
        self.write(cia.VELOCITY_ACTUAL, 0, max(-(2**31), min(2**31 - 1, round(ax.velocity * cpr))))
        rated_t, rated_i = self._rated_torque(), self._rated_current()
        self.write(cia.TORQUE_ACTUAL, 0, max(-32768, min(32767, round(ax.torque / rated_t * 1000.0))))
        self.write(cia.CURRENT_ACTUAL, 0, max(-32768, min(32767, round(ax.current / rated_i * 1000.0))))
        if self.read(cia.MODES_DISPLAY) == Mode.CSP:
            self.write(cia.FOLLOWING_ERROR_ACTUAL, 0, self.read(cia.TARGET_POSITION) - pos)
        i_dq = getattr(ax, "i_dq", None)
        if i_dq is not None:
            self.write(cia.DQ_CURRENT, 1, round(i_dq.real * 1000.0))  # mA
            self.write(cia.DQ_CURRENT, 2, round(i_dq.imag * 1000.0))
            self.write(cia.FRAME_ANGLE, 0, round(ax.position * 1e6))  # urad
            self.write(cia.FRAME_SPEED, 0, round(ax.velocity * 1000.0))  # mrad/s
        ax.latch()
        self._latch_status()
