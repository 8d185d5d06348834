"""What ``rig identify`` asks of an identification experiment (``Request``), its defaults filled
in and its numbers checked before anything is opened (``resolved``); ``PlanError`` when it cannot
run: one line naming the option as ``rig identify`` spells it, and the value.
"""

from __future__ import annotations

import dataclasses

__all__ = [
    "DITHER",
    "MAX_DURATION",
    "PERIODS",
    "PlanError",
    "Request",
    "closed_loop",
    "measures_response",
    "resolved",
]

MAX_DURATION = 3600.0  #: [s] the longest experiment
#: periods of 1/f_min in a chirp or multisine experiment by default: the first is dropped (the
#: start's transient), the rest are Welch's averages
PERIODS = 41
#: a chirp's or multisine's dither, a fraction of the amplitude (standard deviation): white noise
#: that keeps the encoder's quantisation error from repeating period after period, where it
#: would bias H1 with a coherence near 1 (docs/identification.md)
DITHER = 0.005


class PlanError(ValueError):
    """The request cannot run; the message names the option and its value."""


@dataclasses.dataclass(frozen=True)
class Request:
    """What was asked for: ``rig identify``'s options of the same names (None: the default).

    Attributes
    ----------
    input : str
        "voltage" (the armature voltage) or "torque" (a commercial drive's CST).
    excitation : str | None
        prbs, steps, chirp, multisine or friction.
    duration : float | None
        [s] the experiment's length.
    f_min : float
        [Hz] the lowest frequency, a periodic excitation's period.
    f_max : float | None
        [Hz] the highest frequency.
    seed : int
        The excitation's seed.
    u0 : float | None
        [V or N m] the operating point.
    amplitude : float | None
        [V or N m] the excitation's amplitude.
    clock : float | None
        [s] a PRBS bit's time.
    loop_model : str | None
        The identification (file or run directory) the closed loop's gains come from.
    loop_bandwidth : float | None
        [Hz] the closed loop's crossover.
    speed : float | None
        [rad/s] the closed-loop experiment's speed.
    """

    input: str = "voltage"
    excitation: str | None = None
    duration: float | None = None
    f_min: float = 1.0
    f_max: float | None = None
    seed: int = 0
    u0: float | None = None
    amplitude: float | None = None
    clock: float | None = None
    loop_model: str | None = None
    loop_bandwidth: float | None = None
    speed: float | None = None


def measures_response(request: Request) -> bool:
    """Whether the excitation measures the frequency response (chirp, multisine).

    Parameters
    ----------
    request : Request
        What was asked for.

    Returns
    -------
    bool
        It does.

    Raises
    ------
    PlanError
        If the band is not 0 < f_min < f_max.
    """
    from rig.identify.frequency import FREQUENCY_EXCITATIONS

    if request.f_min <= 0.0:
        raise PlanError(f"argument --f-min: must be > 0 Hz, got {request.f_min:g}")
    if request.f_max is not None and request.f_max <= request.f_min:
        raise PlanError(f"need 0 < --f-min ({request.f_min:g}) < --f-max ({request.f_max:g}) [Hz]")
    return request.excitation in FREQUENCY_EXCITATIONS


def resolved(request: Request) -> Request:
    """``request`` with every default filled in, checked before anything is opened.

    Parameters
    ----------
    request : Request
        What was asked for.

    Returns
    -------
    Request
        No field None but ``f_max``, ``loop_model``, ``loop_bandwidth`` and ``speed``.

    Raises
    ------
    PlanError
        If a number is out of its range.
    """
    torque = request.input == "torque"
    # a torque's PRBS on u0 > 0 runs away where B is small: both directions
    excitation = request.excitation or ("friction" if torque else "prbs")
    friction = excitation == "friction"
    r = dataclasses.replace(request, excitation=excitation)
    r = dataclasses.replace(
        r,
        duration=_default(
            r.duration, PERIODS / r.f_min if measures_response(r) else (10.0 if friction else 5.0)
        ),
        clock=_default(r.clock, 0.25 if friction else 0.02),
        u0=_default(r.u0, 0.01 if torque else 3.0),
        amplitude=_default(r.amplitude, 0.006 if torque else 2.0),
    )
    _check_numbers(r)
    return r


def _default(value: float | None, default: float) -> float:
    return default if value is None else value


def _check_numbers(r: Request) -> None:
    """The experiment's numbers in range (``r`` resolved)."""
    assert r.duration is not None and r.clock is not None and r.u0 is not None and r.amplitude is not None
    if not 0.0 < r.duration <= MAX_DURATION:
        raise PlanError(f"argument --duration: must be in (0, {MAX_DURATION:g}] s, got {r.duration:g}")
    if not 0.0 < r.clock < r.duration:
        raise PlanError(f"argument --clock: must be in (0, --duration) s, got {r.clock:g}")
    if r.seed < 0:
        raise PlanError(f"argument --seed: must be >= 0, got {r.seed}")
    if r.excitation == "friction" or closed_loop(r):
        if not 0.0 < r.amplitude:
            raise PlanError(f"need --amplitude > 0, got {r.amplitude:g}")
    elif not 0.0 < r.amplitude < r.u0:
        raise PlanError(f"need 0 < --amplitude ({r.amplitude:g}) < --u0 ({r.u0:g})")


def closed_loop(r: Request) -> bool:
    """Whether the frequency response is measured in closed loop (a torque's, or --loop-model's).

    Parameters
    ----------
    r : Request
        What was asked for.

    Returns
    -------
    bool
        It is.

    Raises
    ------
    PlanError
        If the band is not 0 < f_min < f_max.
    """
    return measures_response(r) and (r.input == "torque" or r.loop_model is not None)
