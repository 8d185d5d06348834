"""What a CiA 402 drive's process data carry, and the plan each cycle reads them by.

The keys (index, subindex) of the objects the host maps (``SW``, ``CW``, ``POSITION`` ...;
``FEEDBACK``: what the TPDOs may carry, by name) and ``CyclePlan``: made once at set-up for the
mapping in force (``drivers.cia402_mapping``), read as it is by every cycle
(``drivers.cia402_cycle``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from drivers.cia402_pdo import Key
from drivers.cia402_process import ProcessData
from drivers.maps import cia
from drivers.maps.cia import Controlword, Mode
from drivers.tpdo_slot import TpdoSlot

__all__ = [
    "CURRENT",
    "CW",
    "DQ_RX",
    "DQ_TX",
    "FEEDBACK",
    "MODE_SHOWN",
    "POSITION",
    "SW",
    "TORQUE",
    "VELOCITY",
    "CyclePlan",
    "SdoAxis",
]

SW: Key = (cia.STATUSWORD, 0)
CW: Key = (cia.CONTROLWORD, 0)
POSITION: Key = (cia.POSITION_ACTUAL, 0)
VELOCITY: Key = (cia.VELOCITY_ACTUAL, 0)
TORQUE: Key = (cia.TORQUE_ACTUAL, 0)
CURRENT: Key = (cia.CURRENT_ACTUAL, 0)
MODE_SHOWN: Key = (cia.MODES_DISPLAY, 0)
DQ_RX = [(cia.DQ_VOLTAGE, 1), (cia.DQ_VOLTAGE, 2)]
DQ_TX = [SW, (cia.FRAME_ANGLE, 0), (cia.FRAME_SPEED, 0), (cia.DQ_CURRENT, 1), (cia.DQ_CURRENT, 2)]
_ENABLE_OPERATION = int(Controlword.ENABLE_OPERATION)
_RUN_WORD = {Mode.INTERPOLATED_POSITION: _ENABLE_OPERATION | cia.CW_ENABLE_IP}
#: the feedback a drive's TPDOs may carry, by name (``Cia402Mapping.maps``); the position always
FEEDBACK = {
    "position": POSITION,
    "velocity": VELOCITY,
    "mode": MODE_SHOWN,
    "torque": TORQUE,
    "current": CURRENT,
}


class CyclePlan:
    """What the cycle (``drivers.cia402_cycle``) reads from the TPDOs of ``data`` and how it packs
    the RPDO, made once at set-up for the mapping in force (``data``) and ``measures``: the
    feedback's values (velocity where chosen; torque, current: measured), the places of the
    statusword and of 0x6061 (None: not in a TPDO), the RPDO of (controlword, target).

    Parameters
    ----------
    data : ProcessData or None
        The process data in force (None: before set-up, an empty plan).
    measures : frozenset of str
        What the feedback measures (position, velocity, torque, current).
    op_mode : Mode or None
        The axis's mode (its target; ip's controlword).
    velocity : bool
        0x606C is read (else the position's backward difference).
    """

    def __init__(
        self, data: ProcessData | None, measures: frozenset[str], op_mode: Mode | None, velocity: bool = True
    ) -> None:
        self.data, self.measures = data, measures
        self.velocity = velocity  #: 0x606C is read (else the position's backward difference)
        self.position = "position" in measures  #: 0x6064 is read (a speed controller has none)
        self.torque, self.current = "torque" in measures, "current" in measures
        self.feedback: Callable[[], tuple[Any, ...]] = tuple
        self.status: tuple[TpdoSlot, int] | None = None
        self.mode: tuple[TpdoSlot, int] | None = None
        self.rpdo: Callable[..., bytes] | None = None
        #: the controlword of each cycle: enable operation (in ip with bit 4, enable ip mode)
        self.run_word = (
            _RUN_WORD.get(op_mode, _ENABLE_OPERATION) if op_mode is not None else _ENABLE_OPERATION
        )
        if data is None:
            return
        keys = [POSITION] * self.position + [VELOCITY] * velocity + [TORQUE] * self.torque
        keys += [CURRENT] * self.current
        self.feedback = data.reader(keys)
        self.status, self.mode = data.where(SW), data.where(MODE_SHOWN)
        if data.rpdo is not None and op_mode in cia.TARGET_OF_MODE:
            self.rpdo = data.packer((CW, cia.TARGET_OF_MODE[op_mode]))


class SdoAxis(Protocol):
    """What set-up's parts need of any axis they set up (``drivers.cia402.Cia402Axis``): its name
    in messages, whether it is the toolkit's own drive, and its SDO access."""

    @property
    def where(self) -> str:
        """``node 5`` (and the axis on a drive of several), for messages."""

    @property
    def toolkit_drive(self) -> bool:
        """The toolkit's own drive, identified by its 0x1018."""

    def sdo_read(self, index: int, subindex: int = 0) -> Any:
        """An object's value, read by SDO.

        Parameters
        ----------
        index, subindex : int
            The object.

        Returns
        -------
        Any
            Its value.
        """

    def sdo_write(self, index: int, subindex: int, value: Any) -> None:
        """An SDO download.

        Parameters
        ----------
        index, subindex : int
            The object.
        value : Any
            What is written.
        """
