"""The unit of a standard object's value, as CiA 301 and CiA 402 define it.

``object_unit(index)`` says an object's unit in words and, for the quantities a drive scales by
its own factors (CiA 402's position, velocity and acceleration units; per mille of the rated
torque 0x6076 or current 0x6075), which factor turns it into SI: ``kind`` is ``"position"``,
``"velocity"``, ``"acceleration"`` (velocity units per second: CiA 402's default acceleration
unit), ``"torque"`` or ``"current"``; None for a fixed unit (ms, mA, rpm). Objects a standard
gives no unit (a COB-ID, a mode, a word of bits) are not listed; manufacturer objects
(0x2000-0x5FFF) have the units their vendor's manual says, so none here.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["ObjectUnit", "object_unit"]


class ObjectUnit(NamedTuple):
    """An object's unit in words, and the drive's factor to SI that applies to it (``kind``)."""

    words: str
    kind: str | None = None


_POSITION = ObjectUnit("position units", "position")
_VELOCITY = ObjectUnit("velocity units", "velocity")
_ACCELERATION = ObjectUnit("accel. units", "acceleration")
_TORQUE = ObjectUnit("permille torque", "torque")
_CURRENT = ObjectUnit("permille current", "current")
_MS, _US = ObjectUnit("ms"), ObjectUnit("us")

_UNITS: dict[int, ObjectUnit] = {
    # CiA 301
    0x1006: _US,  # communication cycle period
    0x1007: _US,  # synchronous window length
    0x100C: _MS,  # guard time
    0x1017: _MS,  # producer heartbeat time
    0x1016: ObjectUnit("ms (node << 16)"),  # consumer heartbeat time
    # CiA 402: position
    **dict.fromkeys((0x6062, 0x6064, 0x6065, 0x6067, 0x607A, 0x607B, 0x607C, 0x607D, 0x60F4), _POSITION),
    0x6063: ObjectUnit("increments"),  # position actual internal value
    0x60FC: ObjectUnit("increments"),  # position demand internal value
    # velocity
    **dict.fromkeys((0x606B, 0x606C, 0x606D, 0x606F, 0x607F, 0x6081, 0x6082, 0x6099, 0x60FF), _VELOCITY),
    0x60F8: _VELOCITY,  # max slippage
    # acceleration
    **dict.fromkeys((0x6083, 0x6084, 0x6085, 0x609A, 0x60C5, 0x60C6), _ACCELERATION),
    # times
    **dict.fromkeys((0x6066, 0x6068, 0x606E, 0x6070), _MS),
    # torque and current
    **dict.fromkeys((0x6071, 0x6072, 0x6074, 0x6077), _TORQUE),
    0x6087: ObjectUnit("permille torque/s"),  # torque slope
    **dict.fromkeys((0x6073, 0x6078), _CURRENT),
    0x6075: ObjectUnit("mA"),  # motor rated current
    0x6076: ObjectUnit("mN m"),  # motor rated torque
    0x6079: ObjectUnit("mV"),  # DC link circuit voltage
    0x6080: ObjectUnit("rpm"),  # max motor speed
}


def object_unit(index: int) -> ObjectUnit | None:
    """The unit of standard object ``index`` (every sub-index of it), or None where its standard
    gives none or it is a manufacturer's."""
    return _UNITS.get(index)
