"""How the host sets a CiA 402 drive up: the settings it writes, the mode, the target held still.

``Cia402Setup`` is a part of ``drivers.cia402.Cia402Axis``, called from its set-up and before each
enable: ``setting`` writes an entry only where the EDS declares it writable
(``drivers.cia402_access.Setting``), ``set_mode`` writes 0x6060 (never read) and awaits 0x6061,
``hold_still`` sets the target the mode acts on as it stands before an enable. The axis's other
parts: what the drive is (``drivers.cia402_discovery``), its process data
(``drivers.cia402_mapping``), its watch of the host (``drivers.cia402_supervision``). No
manufacturer mode is used but on the toolkit's own drive (``toolkit_drive``, by 0x1018). The part
owns its state; what it needs of its axis is ``SetAxis``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any, Protocol

from drivers.cia402_access import Setting
from drivers.cia402_discovery import Cia402Discovery
from drivers.cia402_pdo import variable
from drivers.cia402_plan import CURRENT, CW, DQ_RX, MODE_SHOWN, POSITION, SW, TORQUE, VELOCITY, SdoAxis
from drivers.errors import ConfigError, DeviceFault
from drivers.identity import TOOLKIT_DRIVE, Identity
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.maps.mode_names import mode_text

__all__ = [
    "CURRENT",
    "CW",
    "DQ_RX",
    "MODE_SHOWN",
    "POSITION",
    "SW",
    "TOOLKIT_DRIVE",
    "TORQUE",
    "VELOCITY",
    "Cia402Setup",
]

log = logging.getLogger(__name__)


#: the target that a mode acts on as it stands once enabled, held at 0 before the enable
_STILL_TARGET: dict[int, int] = {
    Mode.PROFILE_VELOCITY: cia.TARGET_VELOCITY,
    Mode.CSV: cia.TARGET_VELOCITY,
    Mode.PROFILE_TORQUE: cia.TARGET_TORQUE,
    Mode.CST: cia.TARGET_TORQUE,
}

#: before an enable in ip (CiA 402-2's objects, where the drive has them): (index, sub, value, why,
#: required). The host sends one position a SYNC in 0x60C1:01 into a FIFO the drive takes one record
#: an interpolation cycle from (0x60C2 = the SYNC period, written at set-up).
_IP_SETTINGS = (
    (cia.INTERPOLATION_SUBMODE, 0, 0, "linear interpolation", True),
    (cia.INTERPOLATION_SYNC, 2, 1, "an interpolation cycle every SYNC", True),
    (cia.INTERPOLATION_CONFIG, 3, 0, "the ip buffer a FIFO", True),
    (cia.INTERPOLATION_CONFIG, 6, 0, "the ip buffer emptied before the enable (buffer clear)", False),
    (cia.INTERPOLATION_CONFIG, 6, 1, "the ip buffer's access enabled", True),
)
_IP_THEN = (
    "the host sends one position a SYNC (0x60C1:01) into a FIFO the drive takes one record an "
    "interpolation cycle from: run this drive in csp"
)


class SetAxis(SdoAxis, Protocol):
    """What the set-up part needs of its axis (``drivers.cia402.Cia402Axis``): its dictionary, its
    SDO access, what it is (``discovery``) and how to wait."""

    node: Any
    device_id: Identity
    discovery: Cia402Discovery
    idle: Callable[[], None]


class Cia402Setup:
    """The settings, the mode and the held target of a CiA 402 drive (see the module docstring).

    Parameters
    ----------
    axis : SetAxis
        The axis it sets up.
    mode_timeout : float
        [s] how long 0x6061 may take to follow 0x6060.
    """

    def __init__(self, axis: SetAxis, mode_timeout: float = 1.0) -> None:
        self.axis = axis
        self.mode_timeout = mode_timeout  #: [s] how long 0x6061 may take to follow 0x6060

    def setting(
        self, index: int, subindex: int, value: Any, why: str, *, required: bool = False, then: str = ""
    ) -> bool:
        """Write an entry where the EDS declares it writable (``drivers.cia402_access.Setting``).

        Parameters
        ----------
        index, subindex : int
            The entry.
        value : Any
            What it should hold.
        why : str
            What it is for, for messages.
        required : bool
            A refusal is a ConfigError (else one warning).
        then : str
            What to do about a refusal, for the message.

        Returns
        -------
        bool
            The entry holds ``value``.
        """
        setting = Setting(index, subindex, value, why, required, then)
        return setting.apply(
            self.axis.node.object_dictionary, self.axis.sdo_read, self.axis.sdo_write, self.axis.where
        )

    def hold_still(self, mode: int) -> None:
        """Before an enable in ``mode``: CSP's 0x607A is absolute (set to 0x6064, where the drive
        stands); profile and cyclic velocity act on 0x60FF, profile and cyclic torque on 0x6071 as
        they stand (set to 0); profile position and homing start only on a new set-point
        (controlword bit 4, CiA 402-2), so nothing is written for them, nor for a mode the
        toolkit does not know. In ip, ``_IP_SETTINGS`` where the drive has them: no record left
        from before is followed.

        Parameters
        ----------
        mode : int
            The mode the drive is about to be enabled in.
        """
        if mode == Mode.CSP:  # 0x607A is absolute: enabled, the drive goes for it
            self.axis.sdo_write(cia.TARGET_POSITION, 0, int(self.axis.sdo_read(cia.POSITION_ACTUAL)))
            return
        if mode == Mode.INTERPOLATED_POSITION:
            od = self.axis.node.object_dictionary
            for index, sub, value, why, required in _IP_SETTINGS:
                if variable(od, (index, sub)) is not None:
                    self.setting(index, sub, value, why, required=required, then=_IP_THEN)
            return
        target = _STILL_TARGET.get(mode, 0)
        var = variable(self.axis.node.object_dictionary, (target, 0)) if target else None
        if var is not None and var.writable:
            self.axis.sdo_write(target, 0, 0)

    def set_mode(self, mode: Mode) -> None:
        """Write 0x6060 (no read first) and wait for 0x6061 to show it, ``mode_timeout`` [s]; a
        manufacturer mode only on the toolkit's own drive.

        Parameters
        ----------
        mode : Mode
            The mode to set.

        Raises
        ------
        ConfigError
            A manufacturer mode on another drive than the toolkit's, or 0x6060 refused.
        DeviceFault
            0x6061 did not show the mode within ``mode_timeout``.
        """
        if int(mode) < 0 and not self.axis.toolkit_drive:
            who = self.axis.device_id.text()
            raise ConfigError(f"{self.axis.where}: mode {int(mode)} is a manufacturer mode; not on {who}")
        why = f"mode {mode_text(int(mode))}"
        self.setting(
            cia.MODES_OF_OPERATION, 0, int(mode), why, required=True, then=self.axis.discovery.choose()
        )
        deadline = time.monotonic() + self.mode_timeout
        while True:
            shown = self.axis.sdo_read(cia.MODES_DISPLAY)
            if shown == mode:
                return
            if time.monotonic() > deadline:
                raise DeviceFault(
                    f"mode {int(mode)} requested, 0x6061 still shows {shown} after {self.mode_timeout:g} s",
                    device=self.axis.where,
                )
            self.axis.idle()
