"""The cycle of an emulated CiA 402 drive: what it does at each SYNC (lock-step) or at the end of each
period of its own clock (real time), from the commands it holds to the feedback it latches.

``DriveCycle`` is a part of ``plant_emulator.cia402_drive.EmulatedDrive`` (a mixin): the
commands of a period for its shaft (``take_timeline``: a synchronous RPDO at the period's
start, an event RPDO after its latency; none, and the motor coasting, with the power stage off),
the shaft brought to the SYNC (``on_sync_latch``), the drive's own work once a period
(``_cycle``: a due mode switch, a target written by SDO, its profile modes' generators, its
limits, its stop ramps) and the feedback objects and statusword latched at the SYNC (CiA 301:
sampled at the SYNC, sent in its synchronous TPDOs).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from drivers.maps import cia
from drivers.maps.cia import SW_FOLLOWING_ERROR, SW_FOLLOWS_COMMAND, SW_REMOTE, EmcyCode, Mode, PowerState
from plant_emulator.profile_modes import HOME_SWITCH, PROFILE_MODES

if TYPE_CHECKING:
    from plant_emulator.axes import Axis
    from plant_emulator.cia402_state import PowerStateMachine
    from plant_emulator.process_image import ProcessImage
    from plant_emulator.profile_modes import ProfileModes
    from plant_emulator.shaft import Shaft, Timed

__all__ = ["DriveCycle"]

# Module globals for the per-SYNC path: an enum member's lookup (or hash) takes ~0.2 us, a global's 0.03
_CYCLIC = (int(Mode.CSP), int(Mode.CSV), int(Mode.CST))
_ENABLED = PowerState.OPERATION_ENABLED
_IP = int(Mode.INTERPOLATED_POSITION)
_FOLLOWING_ERROR = int(EmcyCode.FOLLOWING_ERROR)


class DriveCycle:
    """See the module docstring."""

    od: Any
    sm: PowerStateMachine
    axis: Axis
    shaft: Shaft
    image: ProcessImage
    profiles: ProfileModes
    period: float
    fault_code: int
    glitch_counts: int
    _pending: list[Timed]
    _t_sync: float
    _sdo_target: bool
    _mode_switch: tuple[int, float] | None

    if TYPE_CHECKING:  # the drive's (and its node's) own, used here

        def _show_mode(self, mode: int) -> None: ...
        def _target(self, mode: int) -> complex: ...
        def _check_limits(self) -> None: ...
        def _stop_reaction(self) -> None: ...
        def _demand(self) -> float | None: ...
        def supervise(self, now: float) -> None: ...

    def take_timeline(self, t_start: float) -> list[Timed]:
        """The commands of the period from ``t_start`` [s], for the shaft, at their offsets into it
        (real time: those due by then, at its start); none (and the axis coasts) when the power
        stage is off.

        Parameters
        ----------
        t_start : float
            [s] the period's start.

        Returns
        -------
        list[Timed]
            The commands, at their offsets [s] into the period.
        """
        if not self.sm.power_stage_on:
            self._pending = []
            self.axis.coast()
            return []
        if self.shaft.clock is None:
            pending, self._pending = self._pending, []
            return [(due - t_start, *rest) for due, *rest in pending]  # type: ignore[misc]
        due = [c for c in self._pending if c[0] <= t_start + 1e-12]
        self._pending = [c for c in self._pending if c[0] > t_start + 1e-12]
        return [(0.0, *rest) for _, *rest in due]  # type: ignore[misc]

    def on_sync_latch(self, timestamp: float) -> None:
        """A SYNC at ``timestamp`` [s]: the shaft advances to it and the drive latches its process data.

        Parameters
        ----------
        timestamp : float
            [s] the SYNC's stamp.
        """
        self.shaft.sync(self, timestamp)  # the shaft at this SYNC, advanced once for all its nodes
        self._t_sync = timestamp
        if self.shaft.clock is None:  # lock-step: the drive's cycle comes with the SYNC
            self._cycle()
        self._latch(ahead=self.shaft.sync_offset)  # sampled at the SYNC (CiA 301), not the period's start

    def on_period(self) -> None:
        """Real time: a period of the drive's own clock has passed (``Shaft.advance_to``): its
        cycle, its objects show the new state (an SDO read needs no SYNC), and its supervision
        (heartbeat consumer, RPDO deadlines) is checked at the period's end, as at each SYNC in
        lock-step: a lost host is noticed within a period of its deadline on the drive's clock,
        however late the emulator's loop ran, and its reaction acts from the next period."""
        self._cycle()
        self._latch()
        self.supervise(self.shaft.t)

    def _cycle(self) -> None:
        """The drive's own work once per period: a due mode switch, a target written by SDO,
        its limits, the stop ramps."""
        if self._mode_switch is not None and self.shaft.t >= self._mode_switch[1] - 1e-9:
            mode, self._mode_switch = self._mode_switch[0], None
            self._show_mode(mode)
        mode = self.od.read(cia.MODES_DISPLAY, 0)
        if self._sdo_target:
            self._sdo_target = False
            if self.sm.state is _ENABLED and mode in self.axis.modes and mode not in PROFILE_MODES:
                self._pending.append((self.shaft.t, self.axis, mode, self._target(mode), False))
        if self.sm.state is _ENABLED and mode in PROFILE_MODES:
            ax = self.axis
            loop, value = self.profiles.cycle(mode, self.period, ax.position, ax.velocity)
            ax.set_command(loop, value)
        self._check_limits()
        self._stop_reaction()

    def _latch_status(self) -> None:
        word = self.sm.statusword() | SW_REMOTE
        mode = 0
        if self.sm.state is _ENABLED:
            mode = self.od.read(cia.MODES_DISPLAY, 0)
            if mode in _CYCLIC:
                word |= SW_FOLLOWS_COMMAND
            elif mode in PROFILE_MODES:
                word |= self.profiles.status
        if self.fault_code == _FOLLOWING_ERROR:
            word |= SW_FOLLOWING_ERROR
        self.profiles.ip.track(mode == _IP)  # leaving OPERATION ENABLED in ip empties its buffer
        self.od.write(cia.STATUSWORD, 0, word)

    def _latch(self, *, ahead: float = 0.0) -> None:
        """The feedback objects, sampled ``ahead`` [s] after the latest period boundary."""
        inputs = HOME_SWITCH if self.profiles.switch(self.axis.position) else 0
        self.image.latch(
            self.axis, demand=self._demand(), inputs=inputs, offset=self.glitch_counts, ahead=ahead
        )
        self.axis.latch()
        self._latch_status()
