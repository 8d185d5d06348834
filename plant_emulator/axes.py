"""The physics behind an emulated drive: what a command does to the motor over h seconds.

An axis takes the command of the active mode in SI (``set_command``) and is
advanced by ``advance(h, t)`` with that command held; the drive splits a SYNC
period at the instant a command takes effect. Modes (CiA 402 0x6060):
-1 voltage [V] (the u of the DC-motor papers), -2 dq voltage [V, complex],
10 CST torque [N m], 9 CSV and 3 PV velocity [rad/s], 8 CSP position [rad] (``Mode``).

``DcServoAxis``: the DC motor (3.4) stepped exactly (ZOH per distinct h),
with the drive's own loops for the other modes: a deadbeat armature-current
loop, a speed PI and a position P, running at ``inner_dt``.
``plant_emulator.grid_axis.GridAxis``: the RL load of the dq-current paper.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from drivers.maps.cia import Mode
from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.friction import held, settle
from plant_emulator.zoh import LinearZOH, unrolled_step3

__all__ = ["Axis", "DcServoAxis", "LoadProfile", "ServoLoops"]

#: modes as module globals for the per-step comparisons (an enum member looked up on its class
#: costs ~0.2 us in CPython 3.11)
_VOLTAGE, _CST, _CSV, _PV = Mode.VOLTAGE, Mode.CST, Mode.CSV, Mode.PROFILE_VELOCITY
#: a DC step in which the shaft stops is taken again in this many parts (``DcServoAxis._step``),
#: and the part in which it stops again, until the parts are no longer than STOP_RESOLUTION
REFINE = 4
STOP_RESOLUTION = 1e-7  #: [s] the instant a shaft stops within a step, to within this

LoadProfile = Callable[[float], float]


class Axis:
    """Interface of the physics behind a drive (see the module docstring)."""

    modes: tuple[Mode, ...] = ()
    load: LoadProfile | None = None  #: load torque T_L [N m] of time [s] on the motion; None: none

    @property
    def position(self) -> float:
        """[rad] (the frame angle for the grid axis)"""
        raise NotImplementedError

    @property
    def velocity(self) -> float:
        """[rad/s]"""
        raise NotImplementedError

    @property
    def current(self) -> float:
        """[A] (|i| for the grid axis)"""
        raise NotImplementedError

    @property
    def torque(self) -> float:
        """[N m]"""
        return 0.0

    def set_command(self, mode: int, value: complex | float, *, computed_one_sync_ago: bool = False) -> None:
        """Take a command; ``computed_one_sync_ago`` marks a synchronous RPDO applied one SYNC
        after the host computed it from the previous sample.

        Parameters
        ----------
        mode : int
            The mode of operation (``Mode``), one of ``modes``.
        value : complex | float
            The command in the mode's SI unit (a complex dq voltage [V] in ``Mode.DQ_VOLTAGE``).
        computed_one_sync_ago : bool, optional
            A synchronous RPDO, applied one SYNC after the host computed it.

        Raises
        ------
        ValueError
            If the axis has no mode ``mode``.
        NotImplementedError
            In this interface: each axis implements it.
        """
        raise NotImplementedError

    def latch(self) -> None:
        """A SYNC: the feedback of this instant is being sampled."""

    def warm(self, period: float) -> None:
        """Compute now what stepping whole periods of ``period`` [s] may need later (real time:
        not under the devices' lock, in a SYNC's answer); nothing here.

        Parameters
        ----------
        period : float
            [s] the period the shaft advances by.
        """

    def advance(self, h: float, t: float) -> None:
        """Integrate the physics over ``h`` [s] from time ``t`` [s] with the command held.

        Parameters
        ----------
        h : float
            [s] the step, >= 0.
        t : float
            [s] the time at its start (for a load profile).

        Raises
        ------
        NotImplementedError
            In this interface: each axis implements it.
        """
        raise NotImplementedError

    def coast(self) -> None:
        """Power stage off: no voltage, no torque.

        Raises
        ------
        NotImplementedError
            In this interface: each axis implements it.
        """
        raise NotImplementedError

    def release(self) -> None:
        """The drive restarts (NMT reset): its controller state is cleared and the power stage
        is off; the motion (angle, speed) stays."""
        self.coast()

    def reset(self) -> None:
        """Back to rest (state zero).

        Raises
        ------
        NotImplementedError
            In this interface: each axis implements it.
        """
        raise NotImplementedError


@dataclass(frozen=True)
class ServoLoops:
    """The drive's inner loops: speed PI (kp [N m s/rad], ki [N m/rad]), position P (kp [1/s])."""

    speed_kp: float  #: [N m s/rad] the speed PI's proportional gain
    speed_ki: float  #: [N m/rad] its integral gain
    position_kp: float  #: [1/s] the position P gain
    max_torque: float  #: [N m]
    max_voltage: float  #: [V], the power stage limit


class DcServoAxis(Axis):
    """DC motor (3.4) behind a servo drive; state [theta, omega, i_r].

    Parameters
    ----------
    motor : DCMotorParams
        The motor's parameters (3.4).
    loops : ServoLoops
        The drive's inner loops.
    inner_dt : float
        [s] the inner loops' period.
    load : LoadProfile | None, optional
        Load torque [N m] of time [s]; None: no load.
    coulomb : float, optional
        [N m] the Coulomb friction T_c (``plant_emulator.friction``).
    """

    modes = (Mode.VOLTAGE, Mode.CST, Mode.CSV, Mode.PROFILE_VELOCITY, Mode.CSP)

    def __init__(
        self,
        motor: DCMotorParams,
        loops: ServoLoops,
        *,
        inner_dt: float,
        load: LoadProfile | None = None,
        coulomb: float = 0.0,
    ) -> None:
        self.motor = motor
        #: Coulomb friction torque T_c [N m], breakaway and kinetic (``plant_emulator.friction``)
        self.coulomb = coulomb
        self.loops = loops
        self.inner_dt = inner_dt
        self.load = load  #: load torque profile [N m] of time [s]; None: no load
        p = motor
        self._A = [[0.0, 1.0, 0.0], [0.0, -p.b / p.j, p.k_t / p.j], [0.0, -p.k_e / p.l_r, -p.r_r / p.l_r]]
        self._B = [[0.0, 0.0], [0.0, -1.0 / p.j], [1.0 / p.l_r, 0.0]]
        self._zoh: dict[float, Callable[[list[float], float, float], None]] = {}
        self.x = [0.0, 0.0, 0.0]
        self.mode: int = Mode.VOLTAGE
        self.command = 0.0
        self._integral = 0.0
        self._enabled = True

    def _step(self, u: float, t_load: float, h: float) -> None:
        """Exact ZOH step of (3.4) over h [s] with u [V] and T_L [N m] held, one precomputed step
        per distinct h, and the Coulomb friction of ``plant_emulator.friction`` held with T_L. A
        shaft stuck at the start that the torque at the step's end breaks loose slips from the
        start (its breakaway is not a step late). A step in which the shaft stops (its speed ends
        on the friction's other side) is taken again in REFINE parts, each choosing its friction,
        the part in which it stops again so, down to parts of STOP_RESOLUTION: the friction turns
        where the shaft stops (within 0.1 us), not at the step's end (docs/emulator.md says what
        holding it to the step's end did). A step in which the shaft does not stop, and every
        step without friction, is the one exact step."""
        step = self._zoh.get(h)
        if step is None:
            step = self._zoh[h] = unrolled_step3(LinearZOH(self._A, self._B, h))
        x, c = self.x, self.coulomb
        if not c:
            step(x, u, t_load)
            return
        start = (x[0], x[1], x[2])
        k_t = self.motor.k_t
        friction, stuck = held(x[1], k_t * x[2] - t_load, c)
        if stuck:
            step(x, u, t_load + friction)
            drive = k_t * x[2] - t_load
            if -c <= drive <= c:
                x[0], x[1] = start[0], 0.0
                return
            x[0], x[1], x[2] = start[0], 0.0, start[2]
            friction = c if drive > 0.0 else -c
        step(x, u, t_load + friction)
        if x[1] * friction < 0.0 and h > STOP_RESOLUTION:
            # it stopped within the step, where the friction turns: that instant to within h / REFINE
            x[0], x[1], x[2] = start
            for _ in range(REFINE):
                self._step(u, t_load, h / REFINE)
            return
        x[1] = settle(x[1], friction)

    def warm(self, period: float) -> None:
        """The exact steps of a whole ``period`` [s] (voltage mode) and of the inner loops' part of
        it, each with its refinements down to STOP_RESOLUTION (a step in which the shaft stops):
        each is a matrix exponential, too slow to compute in a SYNC's preparation under the
        devices' lock (docs/emulator.md).

        Parameters
        ----------
        period : float
            [s] the period the shaft advances by.
        """
        for whole in (period, period / max(1, math.ceil(period / self.inner_dt - 1e-9))):
            h = whole
            while True:  # the same divisions as _step's, so the same keys
                if h not in self._zoh:
                    self._zoh[h] = unrolled_step3(LinearZOH(self._A, self._B, h))
                if not h > STOP_RESOLUTION:
                    break
                h = h / REFINE

    def set_command(self, mode: int, value: complex | float, *, computed_one_sync_ago: bool = False) -> None:
        if mode not in self.modes:
            raise ValueError(f"DC servo axis has no mode {mode}")
        if mode != self.mode:
            self._integral = 0.0
        command = float(value.real if isinstance(value, complex) else value)
        if mode == _VOLTAGE:  # max(-limit, min(limit, command)) without the calls (NaN: +limit)
            limit = self.loops.max_voltage
            command = command if command < limit else limit
            command = command if command > -limit else -limit
        self.mode, self.command = mode, command
        self._enabled = True

    def coast(self) -> None:
        self._enabled = False

    def release(self) -> None:
        self._integral = 0.0
        self.coast()

    def reset(self) -> None:
        self.x[:] = [0.0, 0.0, 0.0]
        self._integral = 0.0

    def _coast(self, t_load: float, h: float) -> None:
        """Power stage off, armature open: i_r = 0 and (3.4) is J dw/dt = -B w - T_L - T_f, solved
        exactly over h [s] with T_L [N m] held; where the friction T_f stops the shaft within h,
        at the instant it stops (the rest of h from rest: stuck, or slipping the other way)."""
        x, c = self.x, self.coulomb
        x[2] = 0.0
        if not c:
            self._coast_for(t_load, h)
            return
        friction, stuck = held(x[1], -t_load, c)
        if stuck:
            return
        rest = self._time_to_rest(x[1], t_load + friction)
        if rest < h:
            self._coast_for(t_load + friction, rest)
            x[1] = 0.0
            self._coast(t_load, h - rest)
            return
        self._coast_for(t_load + friction, h)
        x[1] = settle(x[1], friction)

    def _coast_for(self, torque: float, h: float) -> None:
        """J dw/dt = -B w - ``torque`` [N m] held over h [s], exactly."""
        p, x = self.motor, self.x
        if p.b > 0.0:
            a, w_inf = p.b / p.j, -torque / p.b
            decay = math.exp(-a * h)
            x[0] += w_inf * h + (x[1] - w_inf) * (1.0 - decay) / a
            x[1] = w_inf + (x[1] - w_inf) * decay
        else:
            x[0] += x[1] * h - torque * h * h / (2.0 * p.j)
            x[1] -= torque * h / p.j

    def _time_to_rest(self, w: float, torque: float) -> float:
        """[s] until J dw/dt = -B w - ``torque`` takes ``w`` [rad/s] to 0 (inf: never)."""
        p = self.motor
        if w * torque <= 0.0:
            return math.inf
        if p.b > 0.0:
            return math.log1p(p.b * w / torque) * p.j / p.b
        return p.j * w / torque

    def _torque_to_voltage(self, torque: float, h: float) -> float:
        """Deadbeat armature-current loop: u that takes i_r to torque/k_t over h (omega held)."""
        p, lim = self.motor, self.loops
        i_ref = max(-lim.max_torque, min(lim.max_torque, torque)) / p.k_t
        decay = math.exp(-h * p.r_r / p.l_r)
        u = p.k_e * self.x[1] + p.r_r * (i_ref - decay * self.x[2]) / (1.0 - decay)
        return max(-lim.max_voltage, min(lim.max_voltage, u))

    def _speed_loop(self, w_ref: float, h: float) -> float:
        lim = self.loops
        e = w_ref - self.x[1]
        torque = lim.speed_kp * e + self._integral
        if abs(torque) < lim.max_torque:  # conditional integration (anti-windup)
            self._integral += lim.speed_ki * e * h
        return torque

    def advance(self, h: float, t: float) -> None:
        if h <= 0.0:
            return
        load = self.load
        if self._enabled and self.mode == _VOLTAGE:  # the hot path: one exact ZOH step
            self._step(self.command, 0.0 if load is None else load(t), h)
            return
        if not self._enabled:
            self._coast(0.0 if load is None else load(t), h)
            return
        n = max(1, math.ceil(h / self.inner_dt - 1e-9))
        hs = h / n
        for k in range(n):
            if self.mode == _CST:
                torque = self.command
            elif self.mode in (_CSV, _PV):
                torque = self._speed_loop(self.command, hs)
            else:  # CSP
                torque = self._speed_loop(self.loops.position_kp * (self.command - self.x[0]), hs)
            t_load = 0.0 if load is None else load(t + k * hs)
            self._step(self._torque_to_voltage(torque, hs), t_load, hs)

    @property
    def position(self) -> float:
        return self.x[0]

    @property
    def velocity(self) -> float:
        return self.x[1]

    @property
    def current(self) -> float:
        return self.x[2]

    @property
    def torque(self) -> float:
        return self.motor.k_t * self.x[2]
