"""How the host brings its axes to rest: the one way every run ends, a safe stop or not.

``bring_to_rest``: the neutral command on the commanded axes (zero voltage, torque or
speed; none for a position, ``AxisDriver.neutral_command``), quick stop on every commandable
axis, then SYNC cycles (the drives need them for their feedback, and in lock-step to let
time pass) until every axis reports its own stop ended (``AxisDriver.at_rest``: a CiA 402
drive in SWITCH ON DISABLED or FAULT after its ramp, or at rest in QUICK STOP ACTIVE), or
``timeout`` [s] passes (in cycles of the loop's period, and in wall time: in lock-step at least
``LOCKSTEP_HOLD_WALL``, its cycles being emulated time a loaded machine must not cut short); then disable
every axis. Disabling during the ramp would cut it (CiA 402 transition 12: the motor
coasts), so disable comes only after. Each cycle of the stop, before its SYNC, every
stopping axis keeps its device's watch of the host fed (``AxisDriver.keep_stopping``: a CiA
402 drive's command RPDO with the quick stop and the neutral target) and the host's heartbeat
beats on; a drive's supervision is lifted only by its own ``disable``, once the statusword
shows it disabled (docs/stops.md, "Stops in the right order").

A stop is confirmed only when every axis was disabled and then every shaft stayed at rest:
each axis with a shaft speed (``AxisDriver.has_shaft``; encoders too) kept it within its
at-rest window ``rest_speed`` [rad/s] (or one speed unit of the axis, where that is coarser)
for ``rest_time`` [s] of new samples in a row (``RestWatch``), as CiA 402's "speed = 0" is a
speed within 0x606F for 0x6070. A ramp that ends in a coasting motor, or a drive that lets
go of a turning shaft, is not at rest; nor is a stop in which a device reported a fault (EMCY)
it had not reported before the stop began confirmed (an active load that turned the disabled
shaft up to over-speed, though the drive's fault reaction brought it back). The result
(``StopResult``) says which axes were still turning and at what speed; a stop that was not
confirmed is never reported as a clean one.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from drivers.base import AxisDriver, AxisState
from rig.host.pacing import Pacing

__all__ = ["LOCKSTEP_HOLD_WALL", "RestWatch", "StopResult", "bring_to_rest"]

LOCKSTEP_HOLD_WALL = 30.0  #: [s] of wall time at least for a lock-step stop's ramp, and for its hold

log = logging.getLogger(__name__)


@dataclass
class StopResult:
    """How a stop ended."""

    #: every axis disabled, every shaft at rest for its hold
    confirmed: bool
    #: the axes not at rest: the speed [rad/s] of its last sample (None: none came)
    turning: dict[str, float | None] = field(default_factory=dict)
    #: what went wrong, each in words
    problems: list[str] = field(default_factory=list)


class RestWatch:
    """One axis's rest after its disable: ``see`` each new speed sample; ``done`` once at rest long enough.

    Parameters
    ----------
    window : float
        [rad/s] the at-rest window.
    hold : float
        [s] how long the samples stay in it (``samples`` in a row).
    period : float
        [s] the loop's period.
    """

    def __init__(self, window: float, hold: float, period: float) -> None:
        self.window = window
        self.samples = max(1, math.ceil(hold / period - 1e-9))  #: samples in a row the hold takes
        self.run = 0  #: samples in a row within the window so far
        self.speed: float | None = None  #: the last sample [rad/s]

    @classmethod
    def of(cls, axis: AxisDriver, period: float) -> RestWatch:
        """``axis``'s watch: its ``rest_speed`` (or one speed unit where coarser) and ``rest_time``.

        Parameters
        ----------
        axis : AxisDriver
            The axis.
        period : float
            [s] the loop's period.

        Returns
        -------
        RestWatch
            Its watch.
        """
        return cls(max(axis.rest_speed, axis.quanta()[1]), axis.rest_time, period)

    @property
    def done(self) -> bool:
        """The samples in a row within the window make the hold."""
        return self.run >= self.samples

    def see(self, speed: float | None) -> bool:
        """A new sample; None (none this cycle) counts neither way.

        Parameters
        ----------
        speed : float | None
            [rad/s] the shaft's speed.

        Returns
        -------
        bool
            ``done`` after it.
        """
        if speed is not None:
            self.speed = speed
            self.run = self.run + 1 if abs(speed) <= self.window else 0  # NaN: not at rest
        return self.done


def _retry(axis: AxisDriver, step: Callable[[], object], what: str, tries: int = 5) -> bool:
    """``step`` with up to ``tries`` attempts (the frame carrying it may be lost); True if done."""
    for attempt in range(tries):
        try:
            step()
            return True
        except Exception as exc:
            if attempt == tries - 1:
                log.error("stopping %s: %s failed %d times: %s", axis.where, what, tries, exc)
    return False


def _asked(axis: AxisDriver, ask: Callable[[], object], what: str) -> object:
    """``ask()``, or None where the device does not answer (logged)."""
    try:
        return ask()
    except Exception as exc:
        log.debug("%s: no %s while stopping: %s", axis.where, what, exc)
        return None


def bring_to_rest(
    axes: Sequence[AxisDriver],
    commanded: Sequence[AxisDriver],
    pacing: Pacing,
    *,
    period: float,
    timeout: float,
    realtime: bool,
    heartbeat: Callable[[int], None] | None = None,
) -> StopResult:
    """Bring ``axes`` to rest and disabled (module docstring).

    Parameters
    ----------
    axes : Sequence[AxisDriver]
        Every axis of the run.
    commanded : Sequence[AxisDriver]
        Those commanded, given their neutral command first.
    pacing : Pacing
        The run's pacing (its SYNCs).
    period : float
        [s] the loop's period.
    timeout : float
        [s] for the ramps (in lock-step at least ``LOCKSTEP_HOLD_WALL`` of wall time).
    realtime : bool
        Wait a period between ticks where the host keeps the pace.
    heartbeat : Callable[[int], None] | None
        The host's, beating on meanwhile (None: none).

    Returns
    -------
    StopResult
        Confirmed or not, the axes still turning and the problems.
    """
    faulted = {a: a.fault for a in axes}  # a fault the stop began with is its cause, not news
    ok, stopping = _begin(axes, commanded)
    beat = [heartbeat]
    soft = time.monotonic() + timeout  # wall time too (a dead bus makes each check slow); not in
    deadline = soft if realtime else soft + max(0.0, LOCKSTEP_HOLD_WALL - timeout)  # lock-step's ramp
    keep = functools.partial(_keep, stopping)
    problems = _ramp(stopping, pacing, period, timeout, deadline, realtime=realtime, beat=beat, keep=keep)
    for a in stopping:
        ok &= _retry(a, a.disable, "disable")
    turning = _watch_rest(axes, pacing, period, soft, realtime=realtime, beat=beat, keep=keep)
    for name, speed in turning.items():
        said = "no speed sample" if speed is None else f"{speed:.4g} rad/s"
        problems.append(f"{name}: still turning after the disable ({said})")
    problems += _ended(axes, stopping, faulted)
    for text in problems:
        log.error("stop not confirmed: %s", text)
    return StopResult(ok and not problems, turning, problems)


def _keep(stopping: Sequence[AxisDriver]) -> None:
    """Each stopping axis keeps its device's watch of the host fed (``AxisDriver.keep_stopping``)."""
    for a in stopping:
        _asked(a, a.keep_stopping, "command while stopping")


def _ramp(
    stopping: Sequence[AxisDriver],
    pacing: Pacing,
    period: float,
    timeout: float,
    deadline: float,
    *,
    realtime: bool,
    beat: list[Callable[[int], None] | None],
    keep: Callable[[], None],
) -> list[str]:
    """SYNC cycles until every stopping axis reports its own stop ended (``AxisDriver.at_rest``),
    at most ``timeout`` [s] of periods and the wall-clock ``deadline``; the axes whose ramp did not
    end, in words."""
    pending = list(stopping)

    def rested(a: AxisDriver) -> bool:
        return bool(_asked(a, lambda: a.at_rest(a.feedback()), "state"))

    done = _cycles(
        pacing,
        period,
        timeout,
        deadline,
        realtime=realtime,
        beat=beat,
        keep=keep,
        done=lambda: _pending(pending, rested),
    )
    return [] if done else [f"{a.name}: its stop ramp did not end within {timeout:g} s" for a in pending]


def _watch_rest(
    axes: Sequence[AxisDriver],
    pacing: Pacing,
    period: float,
    soft: float,
    *,
    realtime: bool,
    beat: list[Callable[[int], None] | None],
    keep: Callable[[], None],
) -> dict[str, float | None]:
    """After the disable, each shaft's speed watched until it holds at rest (``RestWatch``), up to
    the stop's wall deadline ``soft`` (monotonic s) and at least three holds; the axes still
    turning, by name, with their last speed [rad/s] (None: no sample)."""
    watches = {a: RestWatch.of(a, period) for a in axes if a.has_shaft}
    hold = max((w.samples for w in watches.values()), default=0) * period
    left = max(soft - time.monotonic(), 3.0 * hold)  # the hold gets its time after a slow ramp
    # in lock-step its cycles are emulated time: over a slow wire (the vcan VM: a few ms a cycle)
    # the wall clock must not cut them short (a shaft at 0 rad/s, its hold unfinished, was "still
    # turning"); a dead wire still ends it, each tick failing or waiting out its answers
    wall = left if realtime else max(left, LOCKSTEP_HOLD_WALL)

    def resting() -> bool:  # every watch sees its sample (a list, not all()'s short cut)
        return all([w.see(_asked(a, a.shaft_speed, "speed")) for a, w in watches.items()])  # type: ignore[arg-type]

    if watches:
        end = time.monotonic() + wall
        _cycles(pacing, period, left, end, realtime=realtime, beat=beat, keep=keep, done=resting)
    return {a.name: w.speed for a, w in watches.items() if not w.done}


def _begin(axes: Sequence[AxisDriver], commanded: Sequence[AxisDriver]) -> tuple[bool, list[AxisDriver]]:
    """The stop's first steps: each commanded axis's neutral command, then every commandable
    axis's quick stop; (all of them done, the axes stopping)."""
    ok = True
    for a in commanded:
        neutral = a.neutral_command()
        if neutral is not None:
            ok &= _retry(a, functools.partial(a.command, neutral), "zero command")
    stopping = [a for a in axes if a.commandable]
    for a in stopping:
        ok &= _retry(a, a.quick_stop, "quick stop")
    return ok, stopping


def _ended(
    axes: Sequence[AxisDriver], stopping: Sequence[AxisDriver], faulted: dict[AxisDriver, Exception | None]
) -> list[str]:
    """What the stop's end found wrong: a fault new since the stop began (``faulted``), an axis
    not disabled (its state asked up to three times: a frame lost on the way is asked again)."""
    problems = []
    for a in axes:
        fault = a.fault
        if fault is not None and fault is not faulted[a]:
            problems.append(f"{a.name}: {fault} during the stop")
    for a in stopping:
        state = None
        for _ in range(3):
            state = state or _asked(a, a.read_state, "state")
        if state not in (AxisState.DISABLED, AxisState.FAULT):
            problems.append(f"{a.name}: not disabled ({getattr(state, 'value', 'no answer')})")
    return problems


def _pending(pending: list[AxisDriver], rested: Callable[[AxisDriver], bool]) -> bool:
    """Drop the axes that ``rested``; True when none is left."""
    pending[:] = [a for a in pending if not rested(a)]
    return not pending


def _cycles(
    pacing: Pacing,
    period: float,
    seconds: float,
    deadline: float,
    *,
    realtime: bool,
    beat: list[Callable[[int], None] | None],
    keep: Callable[[], None],
    done: Callable[[], bool],
) -> bool:
    """SYNC cycles (the host's heartbeat ``beat[0]`` and ``keep()`` before each) until
    ``done()``, for at most ``seconds`` of periods and the wall-clock ``deadline``; True when
    ``done``."""
    for k in range(max(1, math.ceil(seconds / period))):
        if done():
            return True
        if time.monotonic() > deadline:
            return False
        if beat[0] is not None:
            try:
                beat[0](k)
            except Exception as exc:  # the bus is gone: the stop goes on as far as it can
                log.error("the host's heartbeat not sent while stopping: %s", exc)
                beat[0] = None
        if realtime and not pacing.paced_by_bus:
            time.sleep(period)
        keep()
        try:
            pacing.tick()
        except Exception as exc:
            log.error("no SYNC while stopping: %s", exc)
            return False
    return done()
