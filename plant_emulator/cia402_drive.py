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
(0x605A) brake with the speed loop along the ramp their option selects (0x6084,
0x6085 or the current limit; ``plant_emulator.braking``) where the axis has a
speed loop, or coast (option 0). A disable voltage in QUICK STOP ACTIVE cuts the
ramp, as CiA 402 transition 12 does: the motor coasts.
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
    AbortConnectionOption,
    EmcyCode,
    ErrorRegister,
    Mode,
    PowerState,
    QuickStopOption,
    SdoAbortCode,
)
from plant_emulator.axes import Axis
from plant_emulator.braking import STOPPED_SPEED, Braking, deceleration
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
_SIGNED = (
    cia.MODES_OF_OPERATION,
    cia.QUICK_STOP_OPTION,
    cia.FAULT_REACTION_OPTION,
    cia.ABORT_CONNECTION_OPTION,
)
_QUICK_STOP_OPTIONS = frozenset(int(o) for o in QuickStopOption)
S = PowerState
# The per-SYNC path compares with these module globals: CPython 3.11 takes ~0.2 us to look an
# enum member up on its class (and to hash an Enum), ~0.03 us for a global.
_VOLTAGE, _DQ_VOLTAGE, _CST, _CSV, _PV, _CSP = (
    int(m) for m in (Mode.VOLTAGE, Mode.DQ_VOLTAGE, Mode.CST, Mode.CSV, Mode.PROFILE_VELOCITY, Mode.CSP)
)
_CYCLIC = (_CSP, _CSV, _CST)
_ENABLED, _QUICK_STOP_ACTIVE, _REACTION, _FAULT = (
    S.OPERATION_ENABLED,
    S.QUICK_STOP_ACTIVE,
    S.FAULT_REACTION_ACTIVE,
    S.FAULT,
)
_STOPPED = (_FAULT, S.SWITCH_ON_DISABLED)
_OVER_CURRENT, _OVER_SPEED, _FOLLOWING_ERROR = (
    int(c) for c in (EmcyCode.OVER_CURRENT, EmcyCode.OVER_SPEED, EmcyCode.FOLLOWING_ERROR)
)


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
        self._dq_axis = hasattr(axis, "i_dq")  # reports dq current and frame angle
        self._speed_limited = Mode.DQ_VOLTAGE not in axis.modes  # a grid converter has no speed
        self.sm = PowerStateMachine()
        self.braking = Braking()
        self._pending: list[Timed] = []
        self._t_sync = 0.0
        self.glitch_counts = 0  #: fault injection: added to the latched position [increments]
        self._sdo_target = False
        self._in_rpdo = False
        self.fault_code = 0
        self._pending_cw: int | None = None
        super().__init__(node_id, eds, network)
        self.write(cia.SUPPORTED_MODES, 0, sum(MODE_BITS[m] for m in axis.modes))
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
        read = self.od.read
        res = cia.POSITION_ENCODER_RESOLUTION
        return read(res, 1) / (read(res, 2) * 2.0 * math.pi)  # type: ignore[no-any-return]

    def _rated_torque(self) -> float:
        return self.od.read(cia.RATED_TORQUE, 0) / 1000.0  # type: ignore[no-any-return]  # mN m -> N m

    def _rated_current(self) -> float:
        return self.od.read(cia.RATED_CURRENT, 0) / 1000.0  # type: ignore[no-any-return]  # mA -> A

    def _command(self, mode: int) -> complex:
        """The present target of ``mode`` from the object dictionary, in SI."""
        read = self.od.read
        if mode == _VOLTAGE:
            return complex(read(cia.TARGET_VOLTAGE, 0) / 1000.0)  # mV -> V
        if mode == _DQ_VOLTAGE:
            return complex(read(cia.DQ_VOLTAGE, 1), read(cia.DQ_VOLTAGE, 2)) / 1000.0
        if mode == _CST:
            return complex(read(cia.TARGET_TORQUE, 0) / 1000.0 * self._rated_torque())
        if mode in (_CSV, _PV):
            return complex(read(cia.TARGET_VELOCITY, 0) / self.counts_per_rad)
        if mode == _CSP:
            return complex(read(cia.TARGET_POSITION, 0) / self.counts_per_rad)
        return 0j

    # --- object writes -----------------------------------------------------
    def on_write(self, index: int, subindex: int, data: bytes) -> None:
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
        if after is before:
            return
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
        if mode == _CSP:
            return complex(self.axis.position)
        return 0j

    def on_rpdo(self, number: int, *, synchronous: bool) -> None:
        if self._pending_cw is not None:
            cw, self._pending_cw = self._pending_cw, None
            self._apply_controlword(cw)
        if self.sm.state is not _ENABLED:
            return
        mode = self.od.read(cia.MODES_DISPLAY, 0)
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

    def on_abort_connection(self, what: str, code: int) -> None:
        """The host is gone (heartbeat or RPDO lost, NMT stop): the reaction of 0x6007 (CiA 402),
        if the power stage is on."""
        if self.sm.state is not _ENABLED:
            return
        option = self.read(cia.ABORT_CONNECTION_OPTION) if self._has(cia.ABORT_CONNECTION_OPTION) else 0
        log.warning("node %d: %s: abort connection option %d", self.node_id, what, option)
        if option == AbortConnectionOption.FAULT:
            self.raise_fault(code)
        elif option == AbortConnectionOption.DISABLE_VOLTAGE:
            self.sm.disable_voltage()
            self.axis.coast()
            self._latch_status()
        elif option == AbortConnectionOption.QUICK_STOP:
            self.sm.quick_stop()
            self._latch_status()

    def _has(self, index: int) -> bool:
        return index in self.node.object_dictionary

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

    def _acceleration(self, index: int) -> float:
        """An acceleration object (0x6083-0x6085, velocity units per second) in rad/s^2."""
        return self.od.read(index, 0) / self.counts_per_rad  # type: ignore[no-any-return]

    def _stop_reaction(self) -> None:
        """Quick stop (0x605A) or fault reaction (0x605E): brake along the option's ramp to rest
        [below STOPPED_SPEED], or coast (option 0, or no speed loop); ``plant_emulator.braking``."""
        st = self.sm.state
        if st is not _QUICK_STOP_ACTIVE and st is not _REACTION:
            self.braking.release()
            return
        if not self.braking.active:
            option = (
                self.sm.quick_stop_option if st is _QUICK_STOP_ACTIVE else self.read(cia.FAULT_REACTION_OPTION)
            )
            rate = deceleration(
                option,
                profile=self._acceleration(cia.PROFILE_DECELERATION),
                quick_stop=self._acceleration(cia.QUICK_STOP_DECELERATION),
            )
            if rate is None or _CSV not in self.axis.modes:
                self.axis.coast()
                self.sm.reaction_done()
                return
            self.braking.start(self.axis.velocity, rate)
        ref = self.braking.step(self.period)
        self.axis.set_command(_CSV, ref)
        if ref == 0.0 and abs(self.axis.velocity) < STOPPED_SPEED:
            self.sm.reaction_done()
            if self.sm.state in _STOPPED:
                self.axis.coast()

    def _check_limits(self) -> None:
        st = self.sm.state
        if st is _FAULT or st is _REACTION:
            return
        read, ax = self.od.read, self.axis
        code = 0
        i_max = read(cia.MAX_CURRENT, 0) / 1000.0 * self._rated_current()
        w_max = read(cia.MAX_MOTOR_SPEED, 0) * (2.0 * math.pi / 60.0)  # rpm -> rad/s
        if abs(ax.current) > i_max:
            code = _OVER_CURRENT
        elif self._speed_limited and abs(ax.velocity) > w_max:
            code = _OVER_SPEED
        elif st is _ENABLED and read(cia.MODES_DISPLAY, 0) == _CSP:
            error = read(cia.TARGET_POSITION, 0) - read(cia.POSITION_ACTUAL, 0)
            if abs(error) > read(cia.FOLLOWING_ERROR_WINDOW, 0):
                code = _FOLLOWING_ERROR
        if code:
            self.raise_fault(code)

    def raise_fault(self, code: int) -> None:
        """A device fault: state machine transition 13, 0x603F, 0x1001 and EMCY."""
        log.warning("node %d: fault 0x%04X %s", self.node_id, code, FAULT_CODES.get(code, ""))
        self.fault_code = code
        self.sm.fault()
        self._latch_status()  # the statusword says so at once, not at the next SYNC
        self.write(cia.ERROR_CODE, 0, code)
        register = ErrorRegister.GENERIC
        if code >> 12 == 0x2:  # 0x2xxx: current
            register |= ErrorRegister.CURRENT
        elif code >> 8 in (0x81, 0x82):  # 0x81xx/0x82xx: communication (CiA 301)
            register |= ErrorRegister.COMMUNICATION
        elif code >> 12 == 0x8:  # 0x8xxx: monitoring (the profile's control loops)
            register |= ErrorRegister.DEVICE_PROFILE
        self.emcy(code, register)

    def on_sync_latch(self, timestamp: float) -> None:
        self.shaft.sync(self, timestamp)  # the shaft at this SYNC, advanced once for all its nodes
        self._t_sync = timestamp
        if self._sdo_target:
            self._sdo_target = False
            mode = self.read(cia.MODES_DISPLAY)
            if self.sm.state is _ENABLED and mode in self.axis.modes:
                self._pending.append((0.0, self.axis, mode, self._command(mode), False))
        self._check_limits()
        self._stop_reaction()
        self._latch()

    def _latch_status(self) -> None:
        word = self.sm.statusword() | SW_REMOTE
        if self.sm.state is _ENABLED and self.od.read(cia.MODES_DISPLAY, 0) in _CYCLIC:
            word |= SW_FOLLOWS_COMMAND
        if self.fault_code == _FOLLOWING_ERROR:
            word |= SW_FOLLOWING_ERROR
        self.od.write(cia.STATUSWORD, 0, word)

    def _latch(self) -> None:
        ax, write = self.axis, self.od.write
        cpr = self.counts_per_rad
        pos = math.floor(ax.position * cpr) + self.glitch_counts
        write(cia.POSITION_ACTUAL, 0, max(-(2**31), min(2**31 - 1, pos)))
        write(cia.VELOCITY_ACTUAL, 0, max(-(2**31), min(2**31 - 1, round(ax.velocity * cpr))))
        rated_t, rated_i = self._rated_torque(), self._rated_current()
        write(cia.TORQUE_ACTUAL, 0, max(-32768, min(32767, round(ax.torque / rated_t * 1000.0))))
        write(cia.CURRENT_ACTUAL, 0, max(-32768, min(32767, round(ax.current / rated_i * 1000.0))))
        if self.od.read(cia.MODES_DISPLAY, 0) == _CSP:
            write(cia.FOLLOWING_ERROR_ACTUAL, 0, self.od.read(cia.TARGET_POSITION, 0) - pos)
        if self._dq_axis:
            i_dq = ax.i_dq  # type: ignore[attr-defined]
            write(cia.DQ_CURRENT, 1, round(i_dq.real * 1000.0))  # mA
            write(cia.DQ_CURRENT, 2, round(i_dq.imag * 1000.0))
            write(cia.FRAME_ANGLE, 0, round(ax.position * 1e6))  # urad
            write(cia.FRAME_SPEED, 0, round(ax.velocity * 1000.0))  # mrad/s
        ax.latch()
        self._latch_status()
