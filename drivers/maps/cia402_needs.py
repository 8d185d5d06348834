"""What a task needs of a CiA 402 drive's object dictionary, written once for the host and the emulator.

A dictionary (EDS/DCF) that lacks an object the task reads or writes is refused before
anything is sent, in one line naming the file, the objects and the task (``require``),
not met later as an SDO abort, a traceback or a value read as raw bytes.

What CiA 402-2 makes mandatory and the toolkit uses (a drive's other objects are optional:
where it lacks them, the toolkit does without):

- every drive: the device control, controlword 0x6040 and statusword 0x6041; a status
  needs the statusword alone;
- a mode the host selects: modes of operation 0x6060, written, and its display 0x6061,
  read back until it shows the mode;
- each mode the object its command goes to and the actual value it is controlled on:
  profile position and CSP 0x607A/0x6064, profile velocity and CSV 0x60FF/0x606C, profile
  torque and CST 0x6071, homing 0x6098; the toolkit's own voltage modes (its drive only)
  0x2100 and 0x2200.

An emulated drive keeps, besides, what it writes whatever the host does (``EMULATED``):
CiA 301's error register 0x1001 and heartbeat producer time 0x1017, and CiA 402's error
code 0x603F.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from canopen.objectdictionary import INTEGER_TYPES

from drivers.errors import ConfigError
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.maps.eds_values import TYPE_NAMES

__all__ = ["CONTROL", "EMULATED", "MODE_SELECT", "OF_MODE", "STATUS", "missing", "needed", "require"]

STATUS = (cia.STATUSWORD,)  #: reading the drive's state
CONTROL = (cia.CONTROLWORD, cia.STATUSWORD)  #: moving its state machine
MODE_SELECT = (cia.MODES_OF_OPERATION, cia.MODES_DISPLAY)  #: selecting a mode, and seeing it taken

#: each mode's command object and the actual value it is controlled on (CiA 402-2)
OF_MODE: dict[Mode, tuple[int, ...]] = {
    Mode.PROFILE_POSITION: (cia.TARGET_POSITION, cia.POSITION_ACTUAL),
    Mode.PROFILE_VELOCITY: (cia.TARGET_VELOCITY, cia.VELOCITY_ACTUAL),
    Mode.PROFILE_TORQUE: (cia.TARGET_TORQUE,),
    Mode.HOMING: (cia.HOMING_METHOD,),
    Mode.CSP: (cia.TARGET_POSITION, cia.POSITION_ACTUAL),
    Mode.INTERPOLATED_POSITION: (cia.INTERPOLATION_DATA, cia.POSITION_ACTUAL),
    Mode.CSV: (cia.TARGET_VELOCITY, cia.VELOCITY_ACTUAL),
    Mode.CST: (cia.TARGET_TORQUE,),
    Mode.VOLTAGE: (cia.TARGET_VOLTAGE,),
    Mode.DQ_VOLTAGE: (cia.DQ_VOLTAGE,),
}

#: what an emulated drive writes whatever the host does (see the module docstring)
EMULATED = (
    cia.ERROR_REGISTER,
    cia.COB_ID_SYNC,
    cia.PRODUCER_HEARTBEAT,
    cia.ERROR_CODE,
    *CONTROL,
    *MODE_SELECT,
)

#: CiA's names of the objects above, for the messages
_NAMES = {
    cia.ERROR_REGISTER: "Error register",
    cia.COB_ID_SYNC: "COB-ID SYNC",
    cia.PRODUCER_HEARTBEAT: "Producer heartbeat time",
    cia.ERROR_CODE: "Error code",
    cia.CONTROLWORD: "Controlword",
    cia.STATUSWORD: "Statusword",
    cia.MODES_OF_OPERATION: "Modes of operation",
    cia.MODES_DISPLAY: "Modes of operation display",
    cia.TARGET_POSITION: "Target position",
    cia.INTERPOLATION_DATA: "Interpolation data record",
    cia.POSITION_ACTUAL: "Position actual value",
    cia.TARGET_VELOCITY: "Target velocity",
    cia.VELOCITY_ACTUAL: "Velocity actual value",
    cia.TARGET_TORQUE: "Target torque",
    cia.HOMING_METHOD: "Homing method",
    cia.TARGET_VOLTAGE: "drive-rig's target voltage",
    cia.DQ_VOLTAGE: "drive-rig's dq voltage",
}


#: the objects a task needs that are records: ip's data record 0x60C1 (sub 1 a position), the toolkit's
#: dq voltage 0x2200 (sub 1 u_d, 2 u_q)
_RECORDS = frozenset({cia.INTERPOLATION_DATA, cia.DQ_VOLTAGE})


def needed(mode: Mode | int, *, manufacturer: bool = True) -> tuple[int, ...]:
    """What running the drive in ``mode`` needs: its state machine, the mode's selection, and the
    mode's own objects (``OF_MODE``; none for a mode the toolkit does not run, nor for a
    manufacturer mode unless ``manufacturer``: its objects are those of the toolkit's own drive,
    known only once the drive is identified).

    Parameters
    ----------
    mode : Mode | int
        A CiA 402 mode of operation (0x6060 value).
    manufacturer : bool, optional
        Count a manufacturer mode's objects (the toolkit's own drive's).

    Returns
    -------
    tuple[int, ...]
        The object indices needed.
    """
    code = int(mode)
    own = OF_MODE.get(Mode(code), ()) if code in Mode._value2member_map_ else ()
    return (*CONTROL, *MODE_SELECT, *(own if code >= 0 or manufacturer else ()))


def missing(od: Any, indices: Iterable[int]) -> list[int]:
    """The objects of ``indices`` that canopen object dictionary ``od`` lacks, each once, in order.

    Parameters
    ----------
    od : Any
        A canopen object dictionary.
    indices : Iterable[int]
        Object indices.

    Returns
    -------
    list[int]
        Those ``od`` lacks, each once, in order.
    """
    return [i for i in dict.fromkeys(indices) if i not in od]


def _kind(obj: Any) -> str:
    """What ``obj`` is, where it is not the integer variable CiA gives each object here ("" where it is)."""
    if hasattr(obj, "subindices"):
        return "a record or an array"
    if obj.data_type not in INTEGER_TYPES:
        return TYPE_NAMES.get(obj.data_type, f"data type 0x{obj.data_type:04X}")
    return ""


def require(od: Any, indices: Iterable[int], *, source: str, what: str) -> None:
    """ConfigError naming ``source`` (the file), the objects ``od`` lacks and ``what`` needs them;
    or the first that is not an integer variable, as CiA 301/402 define each of them (of a record
    in ``_RECORDS``, its sub 1).

    Parameters
    ----------
    od : Any
        A canopen object dictionary.
    indices : Iterable[int]
        Object indices.
    source : str
        Its file, named in the error.
    what : str
        What needs them, named in the error.

    Raises
    ------
    ConfigError
        If ``od`` lacks one, or one is not an integer variable.
    """
    wanted = list(indices)
    lacks = missing(od, wanted)
    if lacks:
        names = ", ".join(f"0x{i:04X} ({_NAMES.get(i, 'CiA 402')})" for i in lacks)
        raise ConfigError(
            f"{source}: lacks {names}, which {what} needs (CiA 402): give the drive's own EDS/DCF, "
            "which declares them"
        )
    for i in dict.fromkeys(wanted):
        obj = od[i]
        if i in _RECORDS and hasattr(obj, "subindices") and 1 in obj.subindices:
            obj = obj[1]  # the entry the task uses
        kind = _kind(obj)
        if kind:
            raise ConfigError(
                f"{source}: 0x{i:04X} ({_NAMES.get(i, 'CiA 402')}) is {kind}, not the integer variable "
                f"{what} needs (CiA 402): give the drive's own EDS/DCF"
            )
