"""How an emulated CiA 402 drive protects and stops itself, as a real one does.

- Its limits, checked once per control period: over-current 0x2310 (|i| above 0x6073),
  over-speed 0x8400 (|omega| above 0x6080 rpm), following error 0x8611 in CSP and profile
  position (|demand - actual| above 0x6065 for longer than 0x6066 ms).
- A fault: transition 13, 0x603F, 0x1001 (with the bit of the code's class) and EMCY.
- Its own stops: quick stop (0x605A) and fault reaction (0x605E) brake with the speed loop
  along the ramp their option selects (0x6084, 0x6085 or the current limit;
  ``plant_emulator.braking``) where the axis has a speed loop, or coast (option 0); a
  disable voltage in QUICK STOP ACTIVE cuts the ramp, as CiA 402 transition 12 does.
- A lost host (heartbeat, RPDO deadline, NMT stop): the reaction of 0x6007.

``DriveSafety`` is a part of ``EmulatedDrive`` (a mixin): it uses the drive's state machine,
axis, process image and profile.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from drivers.maps import cia
from drivers.maps.cia import AbortConnectionOption, EmcyCode, ErrorRegister, Mode, PowerState
from plant_emulator.braking import STOPPED_SPEED, Braking, deceleration

if TYPE_CHECKING:
    from plant_emulator.axes import Axis
    from plant_emulator.cia402_state import PowerStateMachine
    from plant_emulator.device_profile import DeviceProfile
    from plant_emulator.process_image import ProcessImage
    from plant_emulator.profile_modes import ProfileModes
    from plant_emulator.shaft import Shaft

__all__ = ["FAULT_CODES", "DriveSafety"]

log = logging.getLogger(__name__)

FAULT_CODES: dict[int, str] = {
    EmcyCode.OVER_CURRENT: "over-current",
    EmcyCode.OVER_SPEED: "over-speed",
    EmcyCode.FOLLOWING_ERROR: "following error",
}
S = PowerState
_CSV, _CSP, _PP, _IP = (
    int(Mode.CSV),
    int(Mode.CSP),
    int(Mode.PROFILE_POSITION),
    int(Mode.INTERPOLATED_POSITION),
)
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


class DriveSafety:
    """See the module docstring."""

    node_id: int
    od: Any
    sm: PowerStateMachine
    axis: Axis
    shaft: Shaft
    image: ProcessImage
    profiles: ProfileModes
    profile: DeviceProfile
    braking: Braking
    period: float
    fault_code: int
    _following_since: float | None
    _speed_limited: bool

    if TYPE_CHECKING:  # the drive's (and its node's) own, used here

        def _has(self, index: int) -> bool: ...
        def _option(self, index: int, default: int) -> int: ...
        def _latch_status(self) -> None: ...
        def _target(self, mode: int) -> complex: ...
        def write(self, index: int, subindex: int, value: Any) -> None: ...
        def emcy(self, code: int, register: int, data: bytes = b"") -> None: ...

    def on_abort_connection(self, what: str, code: int) -> None:
        """The host is gone (heartbeat or RPDO lost, NMT stop): the reaction of 0x6007 (CiA 402),
        if the power stage is on.

        Parameters
        ----------
        what : str
            What was lost, for the log.
        code : int
            The fault code of the loss, raised where the option makes it a fault.
        """
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

    def _stop_reaction(self) -> None:
        """Quick stop (0x605A) or fault reaction (0x605E): brake along the option's ramp to rest
        [below STOPPED_SPEED], or coast (option 0, or no speed loop); ``plant_emulator.braking``."""
        st = self.sm.state
        if st is not _QUICK_STOP_ACTIVE and st is not _REACTION:
            self.braking.release()
            return
        if not self.braking.active or self.braking.cause is not st:  # a fault during a quick stop:
            r = self.profile.reactions  # the fault reaction's option from now on (transition 13)
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
                self.braking.release()
                self.axis.coast()
                self.sm.reaction_done()
                return
            self.braking.start(self.axis.velocity, rate, cause=st)
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
        elif self._following_error(st):
            code = _FOLLOWING_ERROR
        if code:
            self.raise_fault(code)

    def _demand(self) -> float | None:
        """The position set-point [rad] of a position mode (CSP, PP), else None."""
        mode = self.od.read(cia.MODES_DISPLAY, 0)
        if mode == _CSP:  # the set-point the position loop follows (a held one, or 0x607A's)
            ax = self.axis
            held = getattr(ax, "command", None) if getattr(ax, "mode", None) == _CSP else None
            return float(held) if held is not None else self._target(_CSP).real
        if mode == _PP:
            return self.profiles.move.position
        if mode == _IP and self.profiles.ip.in_mode:
            return self.profiles.ip.demand  # the interpolator's (plant_emulator.interpolation)
        return None

    def _following_error(self, st: PowerState) -> bool:
        """|demand - actual| above 0x6065 for longer than 0x6066 [ms], in CSP and PP."""
        demand = self._demand() if st is _ENABLED and self._has(cia.FOLLOWING_ERROR_WINDOW) else None
        if demand is None:
            self._following_since = None
            return False
        window = self.od.read(cia.FOLLOWING_ERROR_WINDOW, 0) / self.image.units.position
        if abs(demand - self.axis.position) <= window:
            self._following_since = None
            return False
        now = self.shaft.t
        if self._following_since is None:
            self._following_since = now
        timeout = self._option(cia.FOLLOWING_ERROR_TIMEOUT, 0) / 1000.0  # ms -> s
        return now - self._following_since >= timeout - 1e-9

    def raise_fault(self, code: int) -> None:
        """A device fault: state machine transition 13, 0x603F, 0x1001 and EMCY. A drive whose
        function was disabled (not OPERATION ENABLED nor QUICK STOP ACTIVE: its power stage
        gives no torque) has nothing to brake with: its fault reaction ends at once (transition
        14, FAULT), the motor coasting, where an enabled one brakes along 0x605E's ramp.

        Parameters
        ----------
        code : int
            The fault's error code (0x603F, the EMCY's).
        """
        log.warning("node %d: fault 0x%04X %s", self.node_id, code, FAULT_CODES.get(code, ""))
        self.fault_code = code
        driven = self.sm.state is _ENABLED or self.sm.state is _QUICK_STOP_ACTIVE
        self.sm.fault()
        if not driven and self.sm.state is _REACTION:
            self.braking.release()
            self.axis.coast()
            self.sm.reaction_done()
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
