"""An emulated CiA 402 drive on the bus: any EDS plus a device profile, with an ``Axis`` behind it.

The drive is built from a device profile (``plant_emulator.device_profile``):
its EDS gives the objects, the profile what the EDS cannot (modes where 0x6502
is absent, units, fixed or remappable PDOs, timings, the stop reactions). The
toolkit's own drive is the profile ``drive-rig`` (voltage mode -1 and dq voltage
mode -2 beside CST, CSV, PV and CSP).

Per SYNC (period ``period`` [s]): the physics advances one period with the
commands in force (the drive's ``Shaft``, once for all the nodes on it), the
drive runs its own cycle (a pending mode switch, its limits, the stop ramps)
and latches the feedback into the objects it has (``ProcessImage``, in its own
units) before its synchronous TPDOs go out. A drive whose power stage is off
gives no commands and lets its axis coast; an NMT reset lets go of the axis
(the shaft keeps its motion). Command timing is the two delay cases of the
dq-current paper: a synchronous RPDO (type 0-240) is applied at the next SYNC
(one period of delay: s-PWM-start); an event RPDO (type 254/255) is applied a
latency after receipt (the profile's ``pdo_latency``, or the toolkit's 0x2001
[us]: s-PWM-middle with T_s/2). SDO writes of a target act at the next SYNC.
A write of 0x6060 shows in 0x6061 after the profile's ``mode_switch`` time.

Faults (EMCY with 0x603F and 0x1001): over-current 0x2310 (|i| above 0x6073),
over-speed 0x8400 (|omega| above 0x6080 rpm), following error 0x8611 (CSP,
|error| above 0x6065). The fault reaction (0x605E) and quick stop (0x605A)
brake with the speed loop along the ramp their option selects (0x6084, 0x6085
or the current limit; ``plant_emulator.braking``) where the axis has a speed
loop, or coast (option 0). A disable voltage in QUICK STOP ACTIVE cuts the
ramp, as CiA 402 transition 12 does: the motor coasts. A lost host (heartbeat,
RPDO deadline, NMT stop) gets the reaction of 0x6007.

Writes to the profile's harmful manufacturer objects (e.g. a CAN bit rate at
0x2001) are logged and kept in ``harmful_writes``, so a test can tell that a
host wrote where it must not.
"""

from __future__ import annotations

import functools
import logging

import canopen
from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
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
from plant_emulator.device_profile import DEVICES_DIR, DeviceProfile, load_profile
from plant_emulator.process_image import UNIT_OBJECTS, ProcessImage, Ratings
from plant_emulator.shaft import Shaft, Timed

__all__ = ["FAULT_CODES", "EmulatedDrive", "Ratings", "toolkit_profile"]

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
_CSV, _CSP = int(Mode.CSV), int(Mode.CSP)
_CYCLIC = (_CSP, _CSV, int(Mode.CST))
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


@functools.lru_cache(maxsize=1)
def toolkit_profile() -> DeviceProfile:
    """The profile of the toolkit's own drive (``devices/drive-rig.toml``)."""
    return load_profile(DEVICES_DIR / "drive-rig.toml")


class EmulatedDrive(EmulatedNode):
    """A CiA 402 drive node with ``axis`` behind it; see the module docstring.

    ``profile``: the drive's device profile (default: the toolkit's own). ``shaft``: the plant
    the axis is part of (``plant_emulator.shaft``), shared with the other nodes on it; None
    gives the drive a shaft of its own.
    """

    def __init__(
        self,
        node_id: int,
        network: canopen.Network,
        axis: Axis,
        *,
        period: float,
        profile: DeviceProfile | None = None,
        shaft: Shaft | None = None,
    ) -> None:
        shaft = shaft or Shaft(axis, period=period)
        if axis not in shaft.axes:
            raise ValueError("the drive's axis must be one of its shaft's axes")
        if period != shaft.period:
            raise ValueError(f"the drive's period {period!r} s is not its shaft's, {shaft.period!r} s")
        self.profile = profile or toolkit_profile()
        self.axis = axis
        self.shaft = shaft
        self.period = period
        self._speed_limited = Mode.DQ_VOLTAGE not in axis.modes  # a grid converter has no speed
        self.sm = PowerStateMachine()
        self.braking = Braking()
        self._pending: list[Timed] = []
        self._t_sync = 0.0
        self.glitch_counts = 0  #: fault injection: added to the latched position [position units]
        self._sdo_target = False
        self._in_rpdo = False
        self.fault_code = 0
        self._pending_cw: int | None = None
        self._mode_switch: tuple[int, float] | None = None  #: (mode, device time [s] it shows)
        self.harmful_writes: list[tuple[int, int, bytes]] = []  #: (index, subindex, data)
        super().__init__(node_id, str(self.profile.eds), network)
        self.fixed_mapping = self.profile.mapping == "fixed"
        self._present = frozenset(self.node.object_dictionary.indices)
        self.modes = self._modes()
        self._latency_object = self.profile.role_object("command-latency")
        ratings = Ratings(1.0, 1.0, 3000, 6000)  # until ``rate``: a preset rates every drive
        self.image = ProcessImage(self.od, self._has, self.profile.units, ratings, dq=hasattr(axis, "i_dq"))
        self._defaults()
        shaft.attach(self)

    def _has(self, index: int) -> bool:
        return index in self._present

    def _modes(self) -> tuple[int, ...]:
        """The profile's modes the physics can run (profile modes need the loops they use)."""
        capable = set(self.axis.modes)
        if Mode.CSP in capable:
            capable |= {Mode.PROFILE_POSITION, Mode.HOMING}
        modes = tuple(int(m) for m in self.profile.check_against(self.node.object_dictionary) if m in capable)
        if self._has(cia.SUPPORTED_MODES):
            self.write(cia.SUPPORTED_MODES, 0, sum(MODE_BITS[Mode(m)] for m in modes))
        return modes

    def _defaults(self) -> None:
        """The profile's reaction codes into the objects the drive has (its power-on values)."""
        r = self.profile.reactions
        for index, value in (
            (cia.QUICK_STOP_OPTION, r.quick_stop),
            (cia.FAULT_REACTION_OPTION, r.fault),
            (cia.ABORT_CONNECTION_OPTION, r.abort_connection),
            (cia.HALT_OPTION, r.halt),
        ):
            if self._has(index):
                self.write(index, 0, value)
        self.sm.quick_stop_option = self._option(cia.QUICK_STOP_OPTION, r.quick_stop)

    def _option(self, index: int, default: int) -> int:
        return int(self.read(index)) if self._has(index) else default

    @property
    def lockstep(self) -> bool:
        """True: an event RPDO counts as received at its SYNC and time is the SYNC count (lock-step
        across processes, where a frame's real arrival time is scheduling noise); False: arrival
        times count (real time). A property of the shaft, so the nodes on it agree."""
        return self.shaft.lockstep

    @lockstep.setter
    def lockstep(self, value: bool) -> None:
        self.shaft.lockstep = value

    def rate(self, ratings: Ratings, *, counts_per_rev: int | None) -> None:
        """Take the ratings and the position resolution [increments/rev; None: the drive's own]."""
        self.image.rate(ratings, counts_per_rev)

    @property
    def counts_per_rad(self) -> float:
        """Position units per rad (increments for the toolkit's drive)."""
        return self.image.units.position

    # --- object writes -----------------------------------------------------
    def on_write(self, index: int, subindex: int, data: bytes) -> None:
        if index in self.profile.harmful:
            log.warning(
                "node %d: write of %s to 0x%04X:%d (%s)",
                self.node_id,
                data.hex(),
                index,
                subindex,
                next(m.name for m in self.profile.manufacturer if m.index == index),
            )
            self.harmful_writes.append((index, subindex, bytes(data)))
        value = int.from_bytes(data, "little", signed=index in _SIGNED)
        if index == cia.MODES_OF_OPERATION:
            self._select_mode(value)
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

    def after_write(self, index: int) -> None:
        if index in UNIT_OBJECTS:
            self.image.refresh()

    def _select_mode(self, mode: int) -> None:
        """0x6060: a mode of 0x6502 (else SDO abort 0x06090030), shown in 0x6061 after the
        profile's ``mode_switch`` time."""
        if mode not in self.modes:
            raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
        delay = self.profile.timing.mode_switch
        if delay > 0.0:
            self._mode_switch = (mode, self.shaft.t + delay)
        else:
            self._mode_switch = None
            self.write(cia.MODES_DISPLAY, 0, mode)

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
                self.axis.set_command(mode, complex(self.axis.position) if mode == _CSP else 0j)
            else:  # no mode selected: enabled, but no torque
                self.axis.coast()
        self._latch_status()

    def on_rpdo(self, number: int, *, synchronous: bool) -> None:
        if self._pending_cw is not None:
            cw, self._pending_cw = self._pending_cw, None
            self._apply_controlword(cw)
        if self.sm.state is not _ENABLED:
            return
        mode = self.od.read(cia.MODES_DISPLAY, 0)
        if mode not in self.axis.modes:
            return
        value = self.image.target(mode)
        if synchronous:
            self._pending.append((0.0, self.axis, mode, value, True))
            return
        if self._latency_object is not None:
            latency = self._u(self._latency_object, 0) * 1e-6  # us -> s
        else:
            latency = self.profile.timing.pdo_latency
        arrival = 0.0 if self.lockstep else max(self.rx_time - self._t_sync, 0.0)
        self._pending.append((min(arrival + latency, self.period), self.axis, mode, value, False))

    def on_abort_connection(self, what: str, code: int) -> None:
        """The host is gone (heartbeat or RPDO lost, NMT stop): the reaction of 0x6007 (CiA 402),
        if the power stage is on."""
        if self.sm.state is not _ENABLED:
            return
        option = self._option(cia.ABORT_CONNECTION_OPTION, self.profile.reactions.abort_connection)
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

    def on_reset(self, *, application: bool) -> None:
        """Power-on or NMT reset node: the drive lets go of its axis; the shaft keeps turning."""
        self.axis.release()
        self.sm = PowerStateMachine()
        self.sm.power_on()
        self._pending.clear()
        self._mode_switch = None
        self.fault_code = 0
        if hasattr(self, "image"):  # (not yet at the first power-on)
            self.image.refresh()
            self.sm.quick_stop_option = self._option(cia.QUICK_STOP_OPTION, self.profile.reactions.quick_stop)
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
        """Quick stop (0x605A) or fault reaction (0x605E): brake along the option's ramp to rest
        [below STOPPED_SPEED], or coast (option 0, or no speed loop); ``plant_emulator.braking``."""
        st = self.sm.state
        if st is not _QUICK_STOP_ACTIVE and st is not _REACTION:
            self.braking.release()
            return
        if not self.braking.active:
            r = self.profile.reactions
            option = (
                self.sm.quick_stop_option
                if st is _QUICK_STOP_ACTIVE
                else self._option(cia.FAULT_REACTION_OPTION, r.fault)
            )
            rate = deceleration(
                option,
                profile=self.image.acceleration(cia.PROFILE_DECELERATION, r.profile_deceleration),
                quick_stop=self.image.acceleration(cia.QUICK_STOP_DECELERATION, r.quick_stop_deceleration),
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
        ax, image = self.axis, self.image
        code = 0
        if abs(ax.current) > image.max_current:
            code = _OVER_CURRENT
        elif self._speed_limited and abs(ax.velocity) > image.max_speed:
            code = _OVER_SPEED
        elif (
            st is _ENABLED
            and self._has(cia.FOLLOWING_ERROR_WINDOW)
            and self.od.read(cia.MODES_DISPLAY, 0) == _CSP
        ):
            read = self.od.read
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
        if self._has(cia.ERROR_CODE):
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
        self._cycle()
        self._latch()

    def _cycle(self) -> None:
        """The drive's own work once per period: a due mode switch, a target written by SDO,
        its limits, the stop ramps."""
        if self._mode_switch is not None and self.shaft.t >= self._mode_switch[1] - 1e-9:
            self.write(cia.MODES_DISPLAY, 0, self._mode_switch[0])
            self._mode_switch = None
        if self._sdo_target:
            self._sdo_target = False
            mode = self.read(cia.MODES_DISPLAY)
            if self.sm.state is _ENABLED and mode in self.axis.modes:
                self._pending.append((0.0, self.axis, mode, self.image.target(mode), False))
        self._check_limits()
        self._stop_reaction()

    def _latch_status(self) -> None:
        word = self.sm.statusword() | SW_REMOTE
        if self.sm.state is _ENABLED and self.od.read(cia.MODES_DISPLAY, 0) in _CYCLIC:
            word |= SW_FOLLOWS_COMMAND
        if self.fault_code == _FOLLOWING_ERROR:
            word |= SW_FOLLOWING_ERROR
        self.od.write(cia.STATUSWORD, 0, word)

    def _latch(self) -> None:
        csp = self.od.read(cia.MODES_DISPLAY, 0) == _CSP
        self.image.latch(self.axis, csp=csp, offset=self.glitch_counts)
        self.axis.latch()
        self._latch_status()
