"""The profile modes of an emulated CiA 402 drive (CiA 402-2): profile position, profile velocity,
homing, and halt; the drive's own trajectory generators (``plant_emulator.motion``) once per
control period, setting its speed or position loop.

- Profile velocity (3): 0x60FF reached along 0x6083 (away from zero) and 0x6084 (toward it).
  Statusword bit 10 target reached (within 0x606D, or 1 % of the target and 0.1 rad/s), bit
  12 speed zero.
- Profile position (1): the set-point handshake: a rising controlword bit 4 (new set-point)
  takes 0x607A (relative to the present set-point with bit 6) and sets statusword bit 12
  (set-point acknowledge) until bit 4 falls; with bit 5 (change set immediately) the move
  changes at once, else after the present move ends. The move obeys 0x6081, 0x6083, 0x6084
  and the software position limits 0x607D (bit 11 internal limit active when clamped). Bit 10
  target reached when the set-point has arrived and the motor is within 0x6067 (or, where the
  drive has none, 0.01 rad) of it; with halt set, bit 10 says the axis is at rest (0 while it
  decelerates, 1 once its speed is within 0x606D or 0.1 rad/s), as in profile velocity.
- Homing (6): a rising bit 4 starts the method of 0x6098; bit 12 homing attained, bit 13
  homing error, bit 10 target reached. Methods 35 and 37: the present position is the home
  position. Method 19: the home switch (0x60FD bit 2, on at shaft angles >= the profile's
  ``switch_position``): with it off, move positive at 0x6099:1 until it comes on; then
  negative at 0x6099:2 until it goes off; that edge is the home position. The home position
  reads 0x607C afterwards.
- Halt (controlword bit 8) in these three modes: brake by 0x605D (1: 0x6084, 2: 0x6085, 3/4:
  at the limit) to rest and hold; releasing it resumes (profile position continues its move).

Positions are in the drive's position units, shifted by homing (``ProcessImage.home_shift``).
"""

from __future__ import annotations

import math
from typing import Any

from drivers.maps import cia
from drivers.maps.cia import Mode
from plant_emulator.braking import deceleration
from plant_emulator.device_profile import DeviceProfile
from plant_emulator.interpolation import Interpolation
from plant_emulator.motion import PositionProfile, SpeedRamp
from plant_emulator.process_image import ProcessImage

__all__ = ["PROFILE_MODES", "ProfileModes"]

#: the modes whose set-points the drive's own generators make (interpolated position: from the records)
PROFILE_MODES = frozenset(
    {
        int(Mode.PROFILE_POSITION),
        int(Mode.PROFILE_VELOCITY),
        int(Mode.HOMING),
        int(Mode.INTERPOLATED_POSITION),
    }
)
_PP, _PV, _HM = int(Mode.PROFILE_POSITION), int(Mode.PROFILE_VELOCITY), int(Mode.HOMING)
_IP = int(Mode.INTERPOLATED_POSITION)
_CSP, _CSV = int(Mode.CSP), int(Mode.CSV)
NEW_SETPOINT, CHANGE_IMMEDIATELY, RELATIVE, HALT = 1 << 4, 1 << 5, 1 << 6, 1 << 8
TARGET_REACHED, LIMIT_ACTIVE, BIT12, BIT13 = 1 << 10, 1 << 11, 1 << 12, 1 << 13
HOME_SWITCH = 1 << 2  #: 0x60FD bit


class ProfileModes:
    """See the module docstring; ``cycle`` once per period of ``h`` [s] in a profile mode.

    Parameters
    ----------
    od : Any
        The drive's object store.
    has : Any
        Whether the drive has an object (index).
    image : ProcessImage
        Its process image.
    profile : DeviceProfile
        Its device profile.
    """

    def __init__(self, od: Any, has: Any, image: ProcessImage, profile: DeviceProfile) -> None:
        self.od, self.has, self.image, self.profile = od, has, image, profile
        self.ramp = SpeedRamp()
        self.move = PositionProfile()
        self._buffered: float | None = None  #: a set-point waiting for the present move [rad]
        self._last_cw = 0
        self._rising = False
        self.status = 0  #: statusword bits 10-13 of the last cycle
        self.homing: str = "idle"  #: idle, search, back, done, error
        self.limited = False
        self.ip = Interpolation(
            od, has, self.to_si
        )  #: interpolated position (``plant_emulator.interpolation``)

    # --- objects in SI ---------------------------------------------------------------------------
    def _read(self, index: int, sub: int = 0, default: float = 0.0) -> float:
        return float(self.od.read(index, sub)) if self.has(index) else default

    def _velocity(self, index: int, sub: int, default: float) -> float:
        return self._read(index, sub, default * self.image.units.velocity) / self.image.units.velocity

    def _acceleration(self, index: int, default: float) -> float:
        return self.image.acceleration(index, default)

    def to_si(self, position: float) -> float:
        """A position in the drive's units (after homing) in rad.

        Parameters
        ----------
        position : float
            In the drive's units.

        Returns
        -------
        float
            [rad].
        """
        return (position - self.image.home_shift) / self.image.units.position

    def limits(self) -> tuple[float, float]:
        """0x607D in rad (none: infinite).

        Returns
        -------
        tuple[float, float]
            (min, max) [rad].
        """
        if not self.has(cia.SOFTWARE_POSITION_LIMIT):
            return -math.inf, math.inf
        low, high = self.od.read(cia.SOFTWARE_POSITION_LIMIT, 1), self.od.read(cia.SOFTWARE_POSITION_LIMIT, 2)
        return (
            -math.inf if low == -(2**31) else self.to_si(low),
            math.inf if high == 2**31 - 1 else self.to_si(high),
        )

    # --- the cycle -----------------------------------------------------------------------------
    def start(self, position: float, velocity: float) -> None:
        """Enabled (or a mode entered): the generators start where the motor is [rad, rad/s].

        Parameters
        ----------
        position : float
            [rad].
        velocity : float
            [rad/s].
        """
        self.ramp.value = velocity
        self.move = PositionProfile(position, 0.0)
        self._buffered = None
        self.homing = "idle"
        self.ip.start(position)

    def controlword(self, cw: int) -> None:
        """A controlword written (SDO or RPDO): a rising bit 4 is kept for the next cycle (in ip,
        enable ip mode: ``plant_emulator.interpolation``).

        Parameters
        ----------
        cw : int
            The controlword.
        """
        if cw & NEW_SETPOINT and not self._last_cw & NEW_SETPOINT:
            self._rising = True
        self._last_cw = cw
        self.ip.controlword(cw)

    def cycle(self, mode: int, h: float, position: float, velocity: float) -> tuple[int, float]:
        """One period: (the loop to command, its set-point SI); ``status`` holds the bits.

        Parameters
        ----------
        mode : int
            The mode of operation (pp, pv, hm, ip).
        h : float
            [s] the period.
        position : float
            [rad] where the motor is.
        velocity : float
            [rad/s] its speed.

        Returns
        -------
        tuple[int, float]
            (the loop to command, its set-point in SI).
        """
        cw = self._last_cw
        rising, self._rising = self._rising, False
        halt = bool(cw & HALT)
        if mode == _PV:
            return self._pv(h, halt, velocity)
        if mode == _PP:
            return self._pp(h, cw, rising, halt, position, velocity=velocity)
        if mode == _IP:
            demand = self.ip.cycle(h, position)
            self.status = self.ip.status
            return _CSP, demand
        return self._hm(h, rising, halt, position, velocity)

    def _halt_decel(self) -> float:
        r = self.profile.reactions
        option = int(self._read(cia.HALT_OPTION, 0, r.halt))
        rate = deceleration(
            option,
            profile=self._acceleration(cia.PROFILE_DECELERATION, r.profile_deceleration),
            quick_stop=self._acceleration(cia.QUICK_STOP_DECELERATION, r.quick_stop_deceleration),
        )
        return math.inf if rate is None else rate

    def _pv(self, h: float, halt: bool, velocity: float) -> tuple[int, float]:
        r = self.profile.reactions
        accel = self._acceleration(cia.PROFILE_ACCELERATION, r.profile_deceleration)
        decel = self._acceleration(cia.PROFILE_DECELERATION, r.profile_deceleration)
        target = 0.0 if halt else self._velocity(cia.TARGET_VELOCITY, 0, 0.0)
        if halt:
            decel = self._halt_decel()
        ref = self.ramp.step(target, accel, decel, h)
        window = self._velocity(cia.VELOCITY_WINDOW, 0, max(0.1, 0.01 * abs(target)))
        self.status = TARGET_REACHED if ref == target and abs(velocity - target) <= window else 0
        if abs(velocity) <= window:
            self.status |= BIT12  # speed is zero
        return _CSV, ref

    def _pp(
        self, h: float, cw: int, rising: bool, halt: bool, position: float, *, velocity: float
    ) -> tuple[int, float]:
        ack = self.status & BIT12
        if rising:
            raw = self.od.read(cia.TARGET_POSITION, 0)
            if cw & RELATIVE:
                target = self.move.target + raw / self.image.units.position
            else:
                target = self.to_si(raw)
            low, high = self.limits()
            self.limited = not low <= target <= high
            target = min(max(target, low), high)
            if cw & CHANGE_IMMEDIATELY or self.move.done:
                self.move.target, self._buffered = target, None
            else:
                self._buffered = target
            ack = BIT12
        elif not cw & NEW_SETPOINT:
            ack = 0
        if self.move.done and self._buffered is not None:
            self.move.target, self._buffered = self._buffered, None
        v_max = self._velocity(cia.PROFILE_VELOCITY, 0, self.image.max_speed)
        r = self.profile.reactions
        accel = self._acceleration(cia.PROFILE_ACCELERATION, r.profile_deceleration)
        decel = self._acceleration(cia.PROFILE_DECELERATION, r.profile_deceleration)
        if halt:  # bit 10: the axis is at rest (CiA 402 profile position, halt = 1)
            ref = self._hold(h, self._halt_decel())
            reached = not self.move.velocity and abs(velocity) <= self._velocity(cia.VELOCITY_WINDOW, 0, 0.1)
        else:
            ref = self.move.step(v_max, accel, decel, h)
            window = self._read(cia.POSITION_WINDOW, 0, 0.0) / self.image.units.position or 0.01
            reached = self.move.done and abs(position - self.move.target) <= window
        self.status = ack | (TARGET_REACHED if reached else 0) | (LIMIT_ACTIVE if self.limited else 0)
        return _CSP, ref

    def _hold(self, h: float, decel: float) -> float:
        """Halt of a position move: brake its set-point to rest, then hold it there."""
        m = self.move
        if m.velocity:
            v = 0.0 if abs(m.velocity) <= decel * h else m.velocity - math.copysign(decel * h, m.velocity)
            m.position += v * h
            m.velocity = v
        return m.position

    def _hm(self, h: float, rising: bool, halt: bool, position: float, velocity: float) -> tuple[int, float]:
        method = int(self._read(cia.HOMING_METHOD, 0, 35))
        if rising:
            if method not in self.profile.homing.methods:
                self.homing = "error"
            elif method in (35, 37):
                self._set_home(position)
            else:
                self.homing = "back" if self.switch(position) else "search"
        accel = self._acceleration(cia.HOMING_ACCELERATION, self.profile.reactions.profile_deceleration)
        speed = 0.0
        if self.homing == "search":
            speed = self._velocity(cia.HOMING_SPEEDS, 1, 20.0)
            if self.switch(position):
                self.homing = "back"
        if self.homing == "back":
            speed = -self._velocity(cia.HOMING_SPEEDS, 2, 2.0)
            if not self.switch(position):
                self._set_home(position)
                speed = 0.0
        if halt:
            speed, accel = 0.0, self._halt_decel()
        ref = self.ramp.step(speed, accel, accel, h)
        state = self.homing
        self.status = {
            "done": BIT12 | TARGET_REACHED,
            "error": BIT13 | TARGET_REACHED,
            "idle": TARGET_REACHED,
        }.get(state, 0)
        return _CSV, ref

    def switch(self, position: float) -> bool:
        """The home switch at shaft angle ``position`` [rad].

        Parameters
        ----------
        position : float
            [rad] the shaft's angle.

        Returns
        -------
        bool
            The switch is made.
        """
        return position >= self.profile.homing.switch_position

    def _set_home(self, position: float) -> None:
        """The present position reads 0x607C from now on."""
        offset = self._read(cia.HOME_OFFSET, 0, 0.0)
        self.image.home_shift = round(offset) - math.floor(position * self.image.units.position)
        self.homing = "done"
        self.move = PositionProfile(position, 0.0)
