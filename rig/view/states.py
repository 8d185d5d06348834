"""Each axis's state and fault for the live scope, read without any I/O and without writing
anything of the driver's.

- the fault: ``AxisDriver.fault`` (a property), the last fault the device reported (an EMCY's text);
- the state: for a CiA 402 drive, the statusword 0x6041 of its last TPDO decoded by this module
  (the frame's bytes unpacked here, so the driver's own decode cache is never written from the
  viewer's thread), as CiA 402's power state ("OPERATION ENABLED", "FAULT", ...); for any other
  axis "fault" or "running" (its protocol reports no more in its cycle).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from drivers.base import AxisDriver
from drivers.cia402_cycle import power_state
from drivers.maps.cia import STATUSWORD

__all__ = ["axis_state", "state_probe"]


def _statusword(axis: AxisDriver) -> int | None:
    """The statusword of the axis's last TPDO, or None (no CiA 402 process data, none mapped,
    none received)."""
    data = getattr(axis, "data", None)
    where = getattr(data, "where", None)
    if where is None:
        return None
    hit = where((STATUSWORD, 0))
    if hit is None:
        return None
    slot, place = hit
    if slot.timestamp is None:
        return None
    frame = bytes(slot.data)
    if len(frame) != slot.codec.size:
        return None
    return int(slot.codec.unpack(frame)[place])


def axis_state(axis: AxisDriver) -> dict[str, Any]:
    """{"state": text, "fault": text or None, "statusword": int or None} of ``axis`` now.

    Parameters
    ----------
    axis : AxisDriver
        The axis.

    Returns
    -------
    dict[str, Any]
        Its state.
    """
    fault = axis.fault
    try:
        word = _statusword(axis)
    except Exception:  # a driver's internals in a state of change: no state this time
        word = None
    if word is not None:
        state = power_state(word).value
    else:
        state = "fault" if fault is not None else "running"
    return {"state": state, "fault": None if fault is None else str(fault), "statusword": word}


def state_probe(axes: Sequence[AxisDriver]) -> Callable[[], dict[str, dict[str, Any]]]:
    """A function giving every axis's ``axis_state`` by name.

    Parameters
    ----------
    axes : Sequence[AxisDriver]
        The axes.

    Returns
    -------
    Callable[[], dict[str, dict[str, Any]]]
        () -> name -> state.
    """
    held = list(axes)
    return lambda: {a.name: axis_state(a) for a in held}
