"""How the host brings its axes to rest: the one way every run ends, a safe stop or not.

``bring_to_rest``: the neutral command on the commanded axes (zero voltage, torque or
speed; none for a position, ``AxisDriver.neutral_command``), quick stop on every commandable
axis, then SYNC cycles (the drives need them for their feedback, and in lock-step to let
time pass) until every axis reports its own stop ended (``AxisDriver.at_rest``: a CiA 402
drive in SWITCH ON DISABLED or FAULT after its ramp, or at rest in QUICK STOP ACTIVE), or
``timeout`` [s] passes (in cycles of the loop's period, and in wall time); then
disable every axis. Disabling during the ramp would cut it
(CiA 402 transition 12: the motor coasts), so disable comes only after. The result says
whether every stop was confirmed; a stop that was not is never reported as a clean one.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from collections.abc import Callable, Sequence

from drivers.base import AxisDriver
from rig.host.pacing import Pacing

__all__ = ["bring_to_rest"]

log = logging.getLogger(__name__)


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


def _rested(axis: AxisDriver) -> bool:
    try:
        return axis.at_rest(axis.feedback())
    except Exception as exc:
        log.debug("%s: no state while stopping: %s", axis.where, exc)
        return False


def bring_to_rest(
    axes: Sequence[AxisDriver],
    commanded: Sequence[AxisDriver],
    pacing: Pacing,
    *,
    period: float,
    timeout: float,
    realtime: bool,
    heartbeat: Callable[[int], None] | None = None,
) -> bool:
    """See the module docstring; ``period`` [s] of the loop, ``realtime``: wait it between ticks
    where the host keeps the pace; ``heartbeat(k)``: the host's, beating on meanwhile. True
    when every axis confirmed its stop."""
    ok = True
    for a in commanded:
        neutral = a.neutral_command()
        if neutral is not None:
            ok &= _retry(a, functools.partial(a.command, neutral), "zero command")
    stopping = [a for a in axes if a.commandable]
    for a in stopping:
        ok &= _retry(a, a.quick_stop, "quick stop")
    pending = list(stopping)
    deadline = time.monotonic() + timeout  # wall time too: a dead bus makes each check slow
    for k in range(max(1, math.ceil(timeout / period))):
        if not pending or time.monotonic() > deadline:
            break
        if heartbeat is not None:
            try:
                heartbeat(k)
            except Exception as exc:  # the bus is gone: the stop goes on as far as it can
                log.error("the host's heartbeat not sent while stopping: %s", exc)
                heartbeat = None
        if realtime and not pacing.paced_by_bus:
            time.sleep(period)
        try:
            pacing.tick()
        except Exception as exc:
            log.error("no SYNC while stopping: %s", exc)
            break
        pending = [a for a in pending if not _rested(a)]
    for a in pending:
        log.error("%s: its stop was not confirmed within %g s", a.where, timeout)
    for a in stopping:
        ok &= _retry(a, a.disable, "disable")
    return ok and not pending
