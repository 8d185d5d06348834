"""CiA 402's logical devices: a drive of more than one axis on one node, each axis its own objects.

CiA 301 and CiA 402 give a module of several devices (a dual-axis drive, a multi-channel
controller) one object dictionary: the standardized profile area 0x6000-0x9FFF holds up to
eight logical devices of 0x800 objects each, axis n's objects ``0x800 (n - 1)`` above axis 1's
(axis 2's controlword is 0x6840, its statusword 0x6841). Such a module says so in 0x1000: its
additional information (the high word) is FFFFh and its profile (the low word) the first device's;
each logical device gives its own device type at the last index of its range (0x67FF + 0x800 x,
x = 0..7: 0x67FF for axis 1, 0x6FFF for axis 2). Everything outside the profile area (the
communication objects 0x1000-0x1FFF: NMT, SDO, PDOs, EMCY, heartbeat; the manufacturer's
0x2000-0x5FFF) is the node's, shared by its axes.

The offset is applied here and nowhere else, by the host and the emulator alike:

- ``axis_object(index, axis)``: axis ``axis``'s index of profile object ``index`` (as CiA 402
  numbers axis 1's); ``object_axis(index)`` the other way;
- ``axes_of(od)``: how many axes a dictionary describes (the logical devices with a statusword);
- ``axis_dictionary(od, axis)``: the dictionary as one axis sees it, its own profile objects at
  axis 1's indices (each object keeps its own index, which is what goes on the wire), so a
  driver of one axis reads and writes 0x6041 and the SDO carries 0x6841; its ``device`` is the
  whole dictionary, every object at its own index. A dictionary that
  declares fewer axes than asked is refused, naming it; the toolkit's generic dictionary
  (``generic``: a drive met without its EDS) is taken as CiA 402 lays a second axis out, its
  axis-1 objects 0x800 higher.
"""

from __future__ import annotations

import copy
from typing import Any

from drivers.errors import ConfigError

__all__ = [
    "AXIS_OFFSET",
    "DEVICE_TYPE_OF_AXIS",
    "MAX_AXES",
    "MULTIPLE_DEVICES",
    "axes_of",
    "axis_dictionary",
    "axis_object",
    "object_axis",
]

AXIS_OFFSET = 0x800  #: objects per logical device
MAX_AXES = 8  #: logical devices in the standardized profile area 0x6000-0x9FFF
_FIRST, _END = 0x6000, 0x6000 + MAX_AXES * AXIS_OFFSET
DEVICE_TYPE_OF_AXIS = 0x67FF  #: axis 1's device type (its range's last index); axis n's 0x800 (n - 1) higher
MULTIPLE_DEVICES = 0xFFFF  #: 0x1000's additional information (high word) of a module of several devices
_STATUSWORD = 0x6041


def axis_object(index: int, axis: int) -> int:
    """Axis ``axis``'s (1..8) index of profile object ``index`` as CiA 402 numbers it for axis 1
    (0x6000-0x67FF); any other index is the node's, the same for every axis.

    Parameters
    ----------
    index : int
        The object as axis 1's.
    axis : int
        1-8.

    Returns
    -------
    int
        Its index for ``axis``.
    """
    if _FIRST <= index < _FIRST + AXIS_OFFSET:
        return index + AXIS_OFFSET * (axis - 1)
    return index


def object_axis(index: int) -> tuple[int, int]:
    """(the axis 1..8 whose object ``index`` is, its index as axis 1's); (0, ``index``) for an
    object of the node's (outside the profile area).

    Parameters
    ----------
    index : int
        An object's index.

    Returns
    -------
    tuple[int, int]
        (axis 1-8, its index as axis 1's); (0, ``index``) for the node's.
    """
    if _FIRST <= index < _END:
        n, offset = divmod(index - _FIRST, AXIS_OFFSET)
        return n + 1, _FIRST + offset
    return 0, index


def axes_of(od: Any) -> int:
    """How many axes (logical devices with a statusword) the dictionary ``od`` describes: at least 1.

    Parameters
    ----------
    od : Any
        A canopen object dictionary.

    Returns
    -------
    int
        Its axes, >= 1.
    """
    return max(
        [1] + [n for n in range(1, MAX_AXES + 1) if axis_object(_STATUSWORD, n) in od.indices],
    )


def axis_dictionary(od: Any, axis: int, *, source: str, generic: bool = False) -> Any:
    """``od`` (a canopen ObjectDictionary, not used again by the caller) as axis ``axis`` sees it
    (see the module docstring): its attributes ``axis`` and ``axes`` say which and of how many.
    ConfigError naming ``source`` where ``od`` has no such axis (but ``generic``).

    Parameters
    ----------
    od : Any
        A canopen object dictionary (taken over: changed).
    axis : int
        1-8.
    source : str
        Its file, named in the error.
    generic : bool, optional
        The toolkit's generic dictionary (any axis taken).

    Returns
    -------
    Any
        ``od`` as ``axis`` sees it.

    Raises
    ------
    ConfigError
        If ``od`` has no such axis (unless ``generic``).
    """
    if not 1 <= axis <= MAX_AXES:
        raise ConfigError(f"{source}: axis {axis}: a CiA 402 device has axes 1..{MAX_AXES}")
    axes = axes_of(od)
    own = axis_object(_STATUSWORD, axis)
    if axis > axes and not generic:
        has = "axis 1" if axes == 1 else f"an axis it has, 1..{axes}"
        raise ConfigError(
            f"{source} describes a drive of {axes} ax{'es' if axes > 1 else 'is'} (no 0x{own:04X}, axis "
            f"{axis}'s statusword): give {has}, or the EDS/DCF of the drive of several axes"
        )
    view = copy.copy(od)  # its attributes (device information, node id); the tables made anew
    view.indices, view.names = dict(od.indices), dict(od.names)
    view.axis, view.axes, view.device = axis, max(axes, axis), od
    if axis == 1:
        return view
    for index in range(_FIRST, _FIRST + AXIS_OFFSET):
        obj = view.indices.pop(index, None)
        if obj is not None:
            view.names.pop(obj.name, None)
        theirs = od.indices.get(axis_object(index, axis))
        if theirs is None and generic and obj is not None:
            theirs = _shifted(obj, axis_object(index, axis))
        if theirs is not None:
            view.indices[index] = theirs
            view.names.setdefault(theirs.name, theirs)
    return view


def _shifted(obj: Any, index: int) -> Any:
    """A copy of canopen object ``obj`` (a variable, record or array) at ``index``."""
    new = copy.copy(obj)
    new.index = index
    subs = getattr(obj, "subindices", None)
    if subs is not None:
        new.subindices, new.names = {}, {}
        for sub, var in subs.items():
            moved = copy.copy(var)
            moved.index = index
            moved.parent = new
            new.subindices[sub] = moved
            new.names[moved.name] = moved
    return new
