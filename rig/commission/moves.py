"""``rig drive``'s moves on the drive's own profile modes, as an engineer asks for them, each ending
in a short report: ``jog`` (profile velocity at a speed for a while), ``move`` (profile position
to a position, absolute or relative, at a speed and acceleration, optionally held there) and
``home`` (homing by a method). One meaning per option: ``max_speed`` [rad/s] is the fastest the
shaft may turn in any move (the motion watch stops it beyond), ``max_travel`` [rad] the farthest a
move may go; ``speed`` [rad/s] and ``accel`` [rad/s^2] are what the move asks of the drive's
profile (0x6081, 0x6083/0x6084), written only where the drive declares them writable.

Each move runs through ``DriveTool.run_profile`` (enable, the move watched at every look, the
drive's own stop to rest, disable) and reports: what was asked, where the shaft ended (SI and the
drive's units), the error, the time, and how it stopped, in words.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from drivers.cia402_access import Setting
from drivers.cia402_units import require
from drivers.errors import ConfigError, DeviceFault
from drivers.identity import read_standard
from drivers.maps import cia
from drivers.maps.cia import Controlword, Mode
from rig.commission.drive import deadline
from rig.commission.motion_watch import MotionWatch, watch_move
from rig.commission.offers import check_offered
from rig.commission.status import UNITS_HINT

if TYPE_CHECKING:
    from rig.commission.drive import DriveTool

__all__ = ["MAX_HOLD", "home", "jog", "move"]

_NEW_SETPOINT = 0x10  #: controlword bit 4: new set-point (profile position, homing)
_RELATIVE = 0x40  #: controlword bit 6: the target is relative (profile position)
_BIT12, _HOMING_ERROR, _TARGET_REACHED = 1 << 12, 1 << 13, 1 << 10  #: set-point ack / attained
_LIMIT, _FOLLOWING_ERROR = 1 << 11, 1 << 13  #: internal limit active; following error (pp)
#: [s] at most a hold lasts (``move --hold`` without a time holds until Ctrl-C or this)
MAX_HOLD = 3600.0


def _profile(tool: DriveTool, speed: float | None, accel: float | None, max_speed: float) -> dict[str, Any]:
    """The move's speed and acceleration written to the drive's profile (0x6081, 0x6083 and 0x6084,
    where it declares them writable), after checking them against ``max_speed``; what it asked."""
    a = tool.axis
    asked: dict[str, Any] = {}
    if speed is not None:
        if not 0.0 < speed <= max_speed:
            raise ConfigError(f"--speed {speed:g} rad/s: must be in (0, --max-speed {max_speed:g}] rad/s")
        raw = round(speed * a.units.velocity)
        Setting(cia.PROFILE_VELOCITY, 0, raw, "the move's speed", True, _then(a)).apply(
            a.node.object_dictionary, a.sdo_read, a.sdo_write, a.where
        )
        asked["speed_rad_s"] = speed
    if accel is not None:
        if not accel > 0.0:
            raise ConfigError(f"--accel {accel:g} rad/s^2: must be > 0")
        raw = round(accel * a.units.velocity)
        for index in (cia.PROFILE_ACCELERATION, cia.PROFILE_DECELERATION):
            Setting(index, 0, raw, "the move's acceleration", True, _then(a)).apply(
                a.node.object_dictionary, a.sdo_read, a.sdo_write, a.where
            )
        asked["accel_rad_s2"] = accel
    return asked


def _own_speed(tool: DriveTool, max_speed: float) -> float | None:
    """A move's speed where none is asked: None (the drive's own profile velocity 0x6081, read
    from it) where that is within ``max_speed`` [rad/s], else ``max_speed``. A drive whose 0x6081
    cannot be read (absent or refused) is refused before anything is sent: its move's speed is
    unknown."""
    a = tool.axis
    raw = a.discovery.optional(cia.PROFILE_VELOCITY)
    if raw is None:
        give = "--speed RAD_S" + ("" if a.eds_given else ", or the drive's own EDS (--eds FILE)")
        raise ConfigError(
            f"{a.where}: the drive's profile velocity 0x6081:00 (the move's speed) cannot be read from "
            f"it (absent or refused): nothing was sent; give {give}"
        )
    own = abs(float(raw)) / a.units.velocity if raw else math.inf  # 0: no speed of its own
    return None if own <= max_speed else max_speed


def _then(a: Any) -> str:
    """What to do where the drive refuses a value of its profile."""
    if a.eds_given:
        return "its EDS and manual say what it takes"
    return "give the drive's own EDS (--eds FILE), which says what it takes"


def _stop_words(result: dict[str, Any]) -> str:
    """How the move ended, in words."""
    state = result["state"]
    if result["stop_confirmed"]:
        return f"at rest and disabled ({state}); the stop confirmed"
    turning = ", ".join(f"{k} at {v} rad/s" for k, v in result["still_turning"].items())
    return f"NOT confirmed: {state}" + (f"; still turning: {turning}" if turning else "")


def jog(
    tool: DriveTool, speed: float, seconds: float, *, max_speed: float = 20.0, accel: float | None = None
) -> dict[str, Any]:
    """Profile velocity at ``speed`` [rad/s] for ``seconds``; |speed| <= ``max_speed``, and the
    shaft watched against both (``MotionWatch``); the report says the speed it reached.

    Parameters
    ----------
    tool : DriveTool
        The drive.
    speed : float
        [rad/s].
    seconds : float
        [s].
    max_speed : float, optional
        [rad/s] the most allowed.
    accel : float | None, optional
        [rad/s^2] (None: the drive's).

    Returns
    -------
    dict[str, Any]
        The report.

    Raises
    ------
    ConfigError
        If ``speed`` exceeds ``max_speed``, or ``accel`` is not > 0.
    """
    if not abs(speed) <= max_speed:
        raise ConfigError(f"jog speed {speed:g} rad/s exceeds --max-speed {max_speed:g} rad/s")
    a = tool.axis
    late = [deadline(seconds, emulated=tool.emulated)]
    ticks = [0]
    watch: list[MotionWatch] = []
    asked: dict[str, Any] = {}

    def elapsed() -> bool:
        ticks[0] += 1
        return ticks[0] * tool.period >= seconds or late[0]()

    def start() -> None:
        asked.update(_profile(tool, None, accel, max_speed))
        tool.watch_actual(speed, cia.VELOCITY_ACTUAL, a.units.velocity)  # the units: once discovered
        here, _ = tool.actual()
        tool.motion = watch_move(tool, what="the jog", speed_limit=max_speed, asked_speed=speed, start=here)
        watch.append(tool.motion)
        a.sdo_write(cia.TARGET_VELOCITY, 0, round(speed * a.units.velocity))
        late[0] = deadline(seconds, emulated=tool.emulated)  # from its target, not the set-up

    result = tool.run_profile(Mode.PROFILE_VELOCITY, start, elapsed, seconds + 1.0, "the jog")
    reached = watch[0].reached() if watch else math.nan
    return {"asked_rad_s": speed, "reached_rad_s": reached, **asked, "stop": _stop_words(result)} | result


def move(
    tool: DriveTool,
    position: float,
    *,
    relative: bool = False,
    speed: float | None = None,
    accel: float | None = None,
    max_speed: float = 20.0,
    max_travel: float = 10.0,
    hold: float | None = None,
    seconds: float = 30.0,
) -> dict[str, Any]:
    """Profile position to ``position`` [rad] (from where the shaft stands with ``relative``) at
    ``speed`` [rad/s] (default: the drive's 0x6081, at most ``max_speed``) and ``accel``
    [rad/s^2]; the travel at most ``max_travel`` [rad]. ``hold`` [s]: stay enabled at the target
    that long (inf: until Ctrl-C) before the stop. The report says where it ended, the error
    (within the drive's position window 0x6067, or why not) and the time.

    Parameters
    ----------
    tool : DriveTool
        The drive.
    position : float
        [rad].
    relative : bool, optional
        From where the shaft stands.
    speed : float | None, optional
        [rad/s] (None: the drive's 0x6081, at most ``max_speed``).
    accel : float | None, optional
        [rad/s^2] (None: the drive's).
    max_speed : float, optional
        [rad/s].
    max_travel : float, optional
        [rad].
    hold : float | None, optional
        [s] to stay enabled at the target (None: none).
    seconds : float, optional
        [s] it may take.

    Returns
    -------
    dict[str, Any]
        The report.

    Raises
    ------
    ConfigError
        If the speed, acceleration or travel is out of bounds.
    """
    here, target = _target(tool, position, relative=relative, max_travel=max_travel)
    tool.alone()  # no other master: then the profile, written before the enable
    asked = _profile(tool, _own_speed(tool, max_speed) if speed is None else speed, accel, max_speed)
    tool.watch_actual(target, cia.POSITION_ACTUAL, tool.axis.units.position)
    under_way = _Move(tool, here, target, max_speed, hold)
    wait = seconds + (min(hold, MAX_HOLD) if hold is not None else 0.0)
    result = tool.run_profile(Mode.PROFILE_POSITION, under_way.start, under_way.done, wait, "the target")
    return under_way.report(relative, asked, result)


@dataclass
class _Move:
    """A profile-position move under way: what its start, its end and its report share."""

    tool: DriveTool
    here: float  #: [rad] where the shaft stood
    target: float  #: [rad] where it is to go
    max_speed: float  #: [rad/s] the fastest it may turn
    hold: float | None  #: [s] to stay enabled at the target (None: no hold)
    seen: int = 0  #: the statusword at the last look before the stop (its bits 10, 11, 13)
    arrived: float | None = None  #: [s] when the target was first reached (None: not yet)

    def start(self) -> None:
        """Watch the move, write the target and hand it over as a new set-point, acknowledged."""
        tool, a, target = self.tool, self.tool.axis, self.target
        tool.watch_actual(target, cia.POSITION_ACTUAL, a.units.position)
        tool.motion = watch_move(
            tool, what="the move", speed_limit=self.max_speed, start=self.here, target=target
        )
        a.sdo_write(cia.TARGET_POSITION, 0, round(target * a.units.position))
        a.sdo_write(cia.CONTROLWORD, 0, int(Controlword.ENABLE_OPERATION) | _NEW_SETPOINT)
        tool.until(lambda: bool(a.sdo_read(cia.STATUSWORD) & _BIT12), 1.0, "the set-point acknowledge")
        a.sdo_write(cia.CONTROLWORD, 0, int(Controlword.ENABLE_OPERATION))

    def done(self) -> bool:
        """Whether the target is reached (and held for ``hold``, at most ``MAX_HOLD``)."""
        self.seen = int(self.tool.axis.sdo_read(cia.STATUSWORD))
        if not self.seen & _TARGET_REACHED:
            return False
        if self.arrived is None:
            self.arrived = self.tool.elapsed()
        return self.hold is None or self.tool.elapsed() - self.arrived >= min(self.hold, MAX_HOLD)

    def report(self, relative: bool, asked: dict[str, Any], result: dict[str, Any]) -> dict[str, Any]:
        """``move``'s report of the move ended in ``result`` (``asked``: its speed and acceleration)."""
        tool, arrived, reached = self.tool, self.arrived, result["position_rad"]
        report = {
            "target_rad": self.target,
            "relative": relative,
            **asked,
            "reached_rad": reached,
            "time_s": arrived if arrived is not None else tool.elapsed(),
            "held_s": tool.elapsed() - arrived if arrived is not None and self.hold is not None else 0.0,
            **_error(tool, self.target, reached, self.seen),
            "stop": _stop_words(result),
        }
        return report | result


def _target(tool: DriveTool, position: float, *, relative: bool, max_travel: float) -> tuple[float, float]:
    """Before a move, nothing sent: the drive offers profile position and has the factors of its
    target and speed (0x6081); (where the shaft stands, the target) [rad], the travel within
    ``max_travel`` [rad] (ConfigError otherwise)."""
    a = tool.axis
    a.discover(check_mode=False)
    check_offered(a, Mode.PROFILE_POSITION, "move")
    for mode in (Mode.PROFILE_POSITION, Mode.PROFILE_VELOCITY):  # its target and its speed (0x6081)
        require(a.units, int(mode), where=f"{a.name!r} ({a.where})", hint=UNITS_HINT)
    here = a.sdo_read(cia.POSITION_ACTUAL) / a.units.position
    target = here + position if relative else position
    if not abs(target - here) <= max_travel:
        raise ConfigError(f"a move of {target - here:g} rad exceeds --max-travel {max_travel:g} rad")
    return here, target


def _error(tool: DriveTool, target: float, reached: float, word: int) -> dict[str, Any]:
    """The move's error at ``reached`` [rad] from ``target``, in SI and the drive's units, and in
    words: within the drive's position window (0x6067), or said reached by the drive whose window
    cannot be read; else ``stopped_short`` says how far and why (statusword ``word``: an internal
    limit, a following error, no target reached)."""
    a = tool.axis
    short = target - reached
    units = short * a.units.position
    window = read_standard(a.sdo_upload, cia.POSITION_WINDOW)
    out = {"error_rad": short, "error_units": round(units), "short_by_rad": short, "stopped_short": None}
    if word & _TARGET_REACHED and not word & (_LIMIT | _FOLLOWING_ERROR):
        if window is None:
            return out | {"error_said": "the drive said target reached (its position window 0x6067 unread)"}
        if abs(units) <= window + 0.5:
            in_rad = window / a.units.position
            return out | {
                "error_said": f"within the drive's position window (0x6067 = {window}, {in_rad:.4g} rad)"
            }
        why = f"the drive said target reached, outside its position window (0x6067 = {window})"
    elif word & _LIMIT:
        why = "internal limit active (statusword bit 11: a position limit 0x607D or a limit switch)"
    elif word & _FOLLOWING_ERROR:
        why = "following error (statusword bit 13: more than 0x6065 behind the profile)"
    else:
        why = "the drive did not say target reached (statusword bit 10)"
    said = f"stopped {abs(short):.4g} rad ({abs(units):.0f} position units) short of {target:g} rad: {why}"
    return out | {"error_said": said, "stopped_short": said}


def home(
    tool: DriveTool, method: int | None, *, max_speed: float = 20.0, seconds: float = 30.0
) -> dict[str, Any]:
    """Homing with ``method`` (0x6098; None: the drive's); attained or an error; the shaft no
    faster than ``max_speed`` [rad/s].

    Parameters
    ----------
    tool : DriveTool
        The drive.
    method : int | None
        0x6098 (None: the drive's).
    max_speed : float, optional
        [rad/s].
    seconds : float, optional
        [s] it may take.

    Returns
    -------
    dict[str, Any]
        The report.
    """
    a = tool.axis

    def start() -> None:
        tool.watch_actual(0.0, cia.POSITION_ACTUAL, a.units.position)
        tool.motion = watch_move(tool, what="homing", speed_limit=max_speed)  # the position is set anew
        if method is not None:
            a.sdo_write(cia.HOMING_METHOD, 0, method)
        a.sdo_write(cia.CONTROLWORD, 0, int(Controlword.ENABLE_OPERATION) | _NEW_SETPOINT)

    def done() -> bool:
        word = int(a.sdo_read(cia.STATUSWORD))
        if word & _HOMING_ERROR:
            raise DeviceFault(f"homing error (method {method})", device=a.where)
        return bool(word & _BIT12 and word & _TARGET_REACHED)

    result = tool.run_profile(Mode.HOMING, start, done, seconds, "homing")
    return {"method": method, "time_s": tool.elapsed(), "stop": _stop_words(result)} | result
