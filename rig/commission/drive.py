"""Commissioning one CiA 402 drive by SDO (``rig drive``): its status, its state machine, its
objects, and short moves on its own profile generators, each within limits and ending in
the drive's own stop.

``DriveTool`` wraps the driver (``drivers.cia402.Cia402Axis``) for what a lab engineer does
with a new drive before any control law runs: read what it is and how it is set up, enable
and disable it, reset a fault, read and write an object by index or by its EDS name, jog it
in profile velocity, home it, and move it in profile position. A move ends the way every
stop of the toolkit ends: quick stop, the drive's ramp to rest (watched by SDO), disable; so
does a stop signal (Ctrl-C, SIGTERM; ``rig.host.signals``), which no second one cuts short, and
which is then raised again with the stop's confirmation: a move cut short has no result. Time
passes through ``idle`` (a sleep on a real bus; a SYNC in lock-step).
With ``live`` (``rig drive ... --live``) each look at the drive during a move also reads its
actual speed or position by SDO for the live view (``rig.live``).
"""

from __future__ import annotations

import collections
import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

from drivers.cia402 import Cia402Axis
from drivers.errors import DeviceFault, SafetyStop
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.master_watch import MasterWatch
from rig.commission.drive_status import drive_status
from rig.commission.drive_stop import stop_to_rest
from rig.commission.motion_watch import MotionWatch
from rig.commission.objects import object_name, parse_object, read_object
from rig.commission.offers import check_profile
from rig.commission.status import UNITS_HINT
from rig.host.signals import StopRequests

__all__ = ["DriveTool", "deadline", "parse_object"]

log = logging.getLogger(__name__)


#: the ``rig drive`` action that runs the drive in each profile mode
_VERB = {Mode.PROFILE_VELOCITY: "jog", Mode.PROFILE_POSITION: "move", Mode.HOMING: "home"}


def deadline(seconds: float, *, emulated: bool) -> Callable[[], bool]:
    """A predicate, true once ``seconds`` [s] have passed.

    Parameters
    ----------
    seconds : float
        [s].
    emulated : bool
        In lock-step (``DriveTool.emulated``): never true, the callers count their idles.

    Returns
    -------
    Callable[[], bool]
        The predicate, on the wall clock on a real bus.
    """
    if emulated:
        return lambda: False
    end = time.monotonic() + seconds
    return lambda: time.monotonic() >= end


def _report(
    result: str,
    position: float | None,
    velocity: float,
    *,
    confirmed: bool,
    turning: dict[str, float | None],
    state: str,
) -> dict[str, Any]:
    """``DriveTool.run_profile``'s report: how the move ended, the actual values [rad, rad/s]
    after the stop, whether it was confirmed, what was still turning, the state reached."""
    return {
        "result": result,
        **({"position_rad": position} if position is not None else {}),
        "velocity_rad_s": velocity,
        "stop_confirmed": confirmed,
        "still_turning": turning,
        "state": state,
    }


class DriveTool:
    """See the module docstring; ``axis`` is a driver that has not been set up.

    Parameters
    ----------
    axis : Cia402Axis
        A driver not set up.
    idle : Callable[[], None] | None, optional
        Called while waiting (lock-step: advances emulated time; None: sleep).
    period : float, optional
        [s] between looks.
    watch : MasterWatch | None, optional
        A watch for another master (None: none).
    """

    def __init__(
        self,
        axis: Cia402Axis,
        *,
        idle: Callable[[], None] | None = None,
        period: float = 0.01,
        watch: MasterWatch | None = None,
    ) -> None:
        self.axis = axis
        self.watch = watch  #: another master on the bus (None: an in-process twin)
        self.idle = idle or (lambda: time.sleep(period))
        self.period = period  #: [s] between two looks at the drive
        #: lock-step (``idle`` given: a SYNC): time is the count of idles, never the wall clock,
        #: which a loaded machine would run ahead of the drive's
        self.emulated = idle is not None
        axis.idle = self.idle
        axis.discovery.units_hint = UNITS_HINT  # a factor the drive lacks is given by --units here
        axis.eds_hint = "rig drive --eds FILE"  # the device's own dictionary
        #: the move under way, watched at every look (``rig.commission.motion_watch``)
        self.motion: MotionWatch | None = None
        #: ``rig drive --live``: each look during a move appends (t [s], target, actual, target) in SI
        self.live: collections.deque[Sequence[float]] | None = None
        self._watched: tuple[float, int, float] | None = None  #: target [SI], actual's index, its factor
        self._looks = 0
        self._t0 = time.monotonic()

    # --- what the drive is ----------------------------------------------------------------------
    def status(self) -> dict[str, Any]:
        """The drive's whole picture (``rig.commission.drive_status.drive_status``).

        Returns
        -------
        dict[str, Any]
            The picture.
        """
        return drive_status(self.axis)

    def read_object(self, index: int, subindex: int) -> dict[str, Any]:
        """One object read by SDO, for a person (nothing written): ``objects.read_object``.

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        dict[str, Any]
            What ``objects.read_object`` returns.
        """
        return read_object(self.axis, index, subindex)

    def object_name(self, index: int, subindex: int) -> str:
        """An object's name in the drive's EDS (``rig.commission.objects.object_name``).

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        str
            Its name ("" where it has none).
        """
        return object_name(self.axis, index, subindex)

    # --- the state machine ----------------------------------------------------------------------
    def alone(self) -> None:
        """Before an enable or a move: no other master on the bus (``drivers.master_watch``)."""
        if self.watch is not None:
            self.watch.check(max(2.0 * self.period, 0.1), who="rig drive: ", share=False)

    def enable(self, *, timeout: float = 2.0) -> str:
        """OPERATION ENABLED in the mode the drive is in (0x6061; unreadable: held as in CSP), its
        target held where it stands (``Cia402Axis.enable``).

        Parameters
        ----------
        timeout : float, optional
            [s] for the drive to enable.

        Returns
        -------
        str
            The state reached.
        """
        self.axis.discover(check_mode=False)  # the device is its EDS's, before any write
        self.alone()
        shown = self.axis.discovery.optional(cia.MODES_DISPLAY)
        self.axis.nmt("OPERATIONAL")
        self.axis.enable(timeout=timeout, mode=int(Mode.CSP) if shown is None else int(shown))
        return self.axis.read_power_state().value

    def disable(self) -> str:
        """Disable (the identity checked first); the state reached.

        Returns
        -------
        str
            The state.
        """
        self.axis.discover(check_mode=False)  # the device is its EDS's, before any write
        self.axis.disable()
        return self.axis.read_power_state().value

    def reset(self, *, timeout: float = 2.0) -> str:
        """Fault reset (the identity checked first); the state reached and the fault it had.

        Parameters
        ----------
        timeout : float, optional
            [s].

        Returns
        -------
        str
            The state and the fault.
        """
        self.axis.discover(check_mode=False)  # the device is its EDS's, before any write
        was = self.axis.fault_text()
        self.axis.fault_reset(timeout=timeout)
        return f"{self.axis.read_power_state().value} (was: {was})"

    # --- moves ----------------------------------------------------------------------------------
    def until(self, done: Callable[[], bool], seconds: float, what: str) -> None:
        """Look and idle until ``done()``; a SafetyStop naming ``what`` after ``seconds``.

        Parameters
        ----------
        done : Callable[[], bool]
            What is waited for.
        seconds : float
            [s].
        what : str
            Named in the stop.

        Raises
        ------
        SafetyStop
            If it is not done in time.
        """
        late = deadline(seconds, emulated=self.emulated)
        for _ in range(max(1, math.ceil(seconds / self.period))):
            if done():
                return
            if late():
                break
            self.idle()
            self._look()
        if not done():
            raise SafetyStop(f"{self.axis.where}: {what} not within {seconds:g} s")

    def run_profile(
        self, mode: Mode, start: Callable[[], None], done: Callable[[], bool], seconds: float, what: str
    ) -> dict[str, Any]:
        """Enable in ``mode``, ``start``, wait for ``done`` (``seconds``), then the stop; the stop
        also on any error or Ctrl-C. A mode the drive lacks, a factor it needs: refused first.

        Parameters
        ----------
        mode : Mode
            The profile mode.
        start : Callable[[], None]
            Starts the move.
        done : Callable[[], bool]
            The move's end.
        seconds : float
            [s] it may take.
        what : str
            Named in a stop.

        Returns
        -------
        dict[str, Any]
            The report.
        """
        a = self.axis
        check_profile(a, mode, _VERB[mode])
        self.alone()
        confirmed, result = False, "done"
        requests = StopRequests()  # a stop signal is this stop, which no later one cuts short
        requests.install()  # from the enable on: a signal while it enables stops it too
        try:
            try:
                a.nmt("OPERATIONAL")
                a.settings.set_mode(mode)
                a.enable(timeout=2.0, mode=int(mode))
                start()
                self.until(done, seconds, what)
            except KeyboardInterrupt:
                result = "interrupted (Ctrl-C)"
            except (SafetyStop, DeviceFault) as exc:
                result = f"stopped: {exc}"
            finally:
                requests.stopping()
                confirmed, turning = self.stop()
        finally:
            requests.restore()
        requests.pass_on(confirmed)  # a move a signal cut short has no result to report
        position, velocity = self.actual()
        state = a.read_power_state().value
        return _report(result, position, velocity, confirmed=confirmed, turning=turning, state=state)

    def actual(self) -> tuple[float | None, float]:
        """(position [rad], None on a drive without 0x6064; speed [rad/s]) read by SDO.

        Returns
        -------
        tuple[float | None, float]
            (position [rad] or None, speed [rad/s]).
        """
        a = self.axis
        velocity = a.sdo_read(cia.VELOCITY_ACTUAL) / a.units.velocity
        if not a.discovery.has_position:
            return None, velocity
        return a.sdo_read(cia.POSITION_ACTUAL) / a.units.position, velocity

    def watch_actual(self, target: float, actual: int, factor: float) -> None:
        """From now on, with ``live``, each look reads ``actual`` (an object, / ``factor``: SI)
        against ``target`` [SI]; the move's time starts (``elapsed``).

        Parameters
        ----------
        target : float
            [SI].
        actual : int
            The object read.
        factor : float
            Device units per SI unit.
        """
        self._watched = (target, actual, factor)
        self._looks, self._t0 = 0, time.monotonic()

    def elapsed(self) -> float:
        """[s] since ``watch_actual``: looks x period in lock-step, the wall clock's on a bus.

        Returns
        -------
        float
            [s].
        """
        return self._looks * self.period if self.emulated else time.monotonic() - self._t0

    def _look(self) -> None:
        """One look during a move: the motion watch (``MotionWatch``: a SafetyStop where the shaft
        does not do what was asked) and a row for the live view (time [s], lock-step: looks x
        period; target, actual, target)."""
        if self._watched is None or (self.live is None and self.motion is None):
            return
        target, index, factor = self._watched
        self._looks += 1
        t = self.elapsed()
        if self.motion is not None:
            position, speed = self.actual()
            self.motion.see(t, speed, position)
        if self.live is None:
            return
        try:
            actual = self.axis.sdo_read(index) / factor
        except Exception as exc:  # the move's own reads say what is wrong; the live view ends
            log.warning("live view stopped: 0x%04X not read: %s (the move goes on)", index, exc)
            self.live = None
            return
        self.live.append((t, target, actual, target))

    def stop(self, *, seconds: float = 3.0) -> tuple[bool, dict[str, float | None]]:
        """The move's watch ends (``motion``); quick stop, the drive's ramp to rest (statusword
        and 0x606C by SDO), disable (confirmed by the statusword, ``Cia402Axis.disable``: not
        confirmed, the stop is not), then the shaft at rest for the axis's hold
        (``rig.host.stopping.RestWatch``; ``rig.commission.drive_stop``).

        Parameters
        ----------
        seconds : float, optional
            [s] for the drive's ramp.

        Returns
        -------
        tuple[bool, dict[str, float | None]]
            (confirmed, {axis: its speed [rad/s]} where the shaft was still turning).
        """
        self.motion = None
        return stop_to_rest(self.axis, self.until, self.period, seconds)
