"""What an exception out of the host loop's cycles says as its safe stop's reason.

A safety stop (a limit, the watchdog, another master ...) in its own words; a device's fault; a
driver's error, or a send, on a bus that went away as a lost bus; anything else as an exception
in the control loop, logged with its traceback (a bug, not the rig).
"""

from __future__ import annotations

import logging

import can

from drivers.errors import DeviceFault, RigError, SafetyStop, brief
from drivers.master_watch import OtherMaster
from drivers.producer_watch import OtherProducer

__all__ = ["cause_of"]

log = logging.getLogger(__name__)


def cause_of(exc: Exception) -> tuple[str, bool]:
    """The safe stop's reason for ``exc``; call it in the ``except`` block.

    Parameters
    ----------
    exc : Exception
        What the cycles raised.

    Returns
    -------
    tuple[str, bool]
        (the reason, whether a check of a sample raised it: another producer's frame may be the
        cause, ``ProducerWatch.cause``).
    """
    if isinstance(exc, SafetyStop):
        return str(exc), not isinstance(exc, (OtherMaster, OtherProducer))
    if isinstance(exc, DeviceFault):
        return f"device fault: {exc}", False
    if isinstance(exc, RigError):
        if isinstance(exc.__cause__, (OSError, can.CanError)):  # a driver's send on a lost bus
            return f"the bus is lost: {exc}", False
        return f"{type(exc).__name__}: {exc}", False
    if isinstance(exc, (OSError, can.CanError)):  # a send on a bus that went away
        return f"the bus is lost: {type(exc).__name__}: {brief(exc)}", False
    log.exception("exception in the control loop")
    return f"exception in the control loop: {type(exc).__name__}: {exc}", False
