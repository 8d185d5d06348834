"""The end of every move of ``rig drive`` (``DriveTool.stop``): quick stop, the drive's ramp to
rest watched by SDO, disable, then the shaft at rest for the axis's hold."""

from __future__ import annotations

import logging
from collections.abc import Callable

from drivers.cia402 import Cia402Axis
from drivers.errors import RigError, SafetyStop
from drivers.maps import cia
from drivers.maps.cia import PowerState
from rig.host.stopping import RestWatch

__all__ = ["stop_to_rest"]

log = logging.getLogger(__name__)

#: ``DriveTool.until``: look and idle until the predicate holds, a SafetyStop naming the wait after [s]
Until = Callable[[Callable[[], bool], float, str], None]


def stop_to_rest(
    a: Cia402Axis, until: Until, period: float, seconds: float
) -> tuple[bool, dict[str, float | None]]:
    """Quick stop, the drive's ramp to rest (statusword and 0x606C by SDO), disable (confirmed by
    the statusword, ``Cia402Axis.disable``: not confirmed, the stop is not), then the shaft at rest
    for the axis's hold (``rig.host.stopping.RestWatch``).

    Parameters
    ----------
    a : Cia402Axis
        The drive, set up.
    until : Until
        Waits for a predicate (``DriveTool.until``).
    period : float
        [s] between two looks at the drive.
    seconds : float
        [s] for the drive's ramp.

    Returns
    -------
    tuple[bool, dict[str, float | None]]
        (confirmed, {axis: its speed [rad/s]} where the shaft was still turning).
    """
    a.quick_stop()

    def at_rest() -> bool:
        state = a.read_power_state()
        if state in (PowerState.SWITCH_ON_DISABLED, PowerState.FAULT):
            return True
        return bool(abs(a.sdo_read(cia.VELOCITY_ACTUAL) / a.units.velocity) < a.rest_speed)

    try:
        until(at_rest, seconds, "the drive's stop")
        confirmed = True
    except SafetyStop:
        confirmed = False
    try:
        a.disable()  # the drive's own watch of the host is lifted only once it is confirmed
    except RigError as exc:
        log.error("%s: %s", a.where, exc)
        return False, {}
    watch = RestWatch.of(a, period)
    try:
        until(lambda: watch.see(a.shaft_speed()), max(seconds, 3.0 * a.rest_time), "the rest")
    except SafetyStop:
        log.error("%s: still turning after the disable (%s rad/s)", a.where, watch.speed)
        return False, {a.name: watch.speed}
    return confirmed, {}
