"""How the host sets a CiA 402 drive up: discovery, the mode, the process data.

``Cia402Setup`` is the set-up part of ``drivers.cia402.Cia402Axis`` (a mixin over its SDO
access): ``discover`` (``drivers.cia402_discovery``: 0x1000 and the axis, 0x1018, 0x6502 against
the mode, the units of ``drivers.cia402_units``), ``set_mode`` (0x6060 written, never read; 0x6061 awaited),
``map_process_data`` (``drivers.cia402_mapping``), and before each enable the target the mode
acts on as it stands (``_hold_still``); the drive's watch of the host is the axis's part
``drivers.cia402_supervision.DriveSupervision``. It writes no manufacturer
object and uses no manufacturer mode but on the toolkit's own drive (``toolkit_drive``, by
0x1018), and only entries the EDS declares writable (``drivers.cia402_access.Setting``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from drivers.cia402_access import Setting
from drivers.cia402_discovery import Cia402Discovery
from drivers.cia402_mapping import (
    CURRENT,
    CW,
    DQ_RX,
    MODE_SHOWN,
    POSITION,
    SW,
    TORQUE,
    VELOCITY,
    Cia402Mapping,
)
from drivers.cia402_pdo import variable
from drivers.cia402_process import ProcessData
from drivers.cia402_units import DriveUnits
from drivers.errors import ConfigError, DeviceFault
from drivers.identity import TOOLKIT_DRIVE, Identity
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.maps.mode_names import mode_text

if TYPE_CHECKING:
    from drivers.canopen_axis import TpdoSlot

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


class Cia402Setup(Cia402Discovery, Cia402Mapping):
    """See the module docstring."""

    node: Any
    node_id: int
    name: str
    mode: str | None
    op_mode: Mode
    units: DriveUnits
    sync_rpdo: bool
    latency: float
    pdo: str
    mode_timeout: float
    data: ProcessData | None
    measures: frozenset[str]
    idle: Callable[[], None]
    _motion: TpdoSlot | None

    if TYPE_CHECKING:  # the axis's own, used here

        @property
        def where(self) -> str: ...
        def sdo_read(self, index: int, subindex: int = 0) -> Any: ...
        def sdo_write(self, index: int, subindex: int, value: Any) -> None: ...
        def receive_cob(self, cob_id: int, codec: Any) -> TpdoSlot: ...
        def sdo_upload(self, index: int, subindex: int = 0) -> bytes: ...
        def check_identity(self, *, give: str) -> Identity: ...

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
        return setting.apply(self.node.object_dictionary, self.sdo_read, self.sdo_write, self.where)

    def _hold_still(self, mode: int) -> None:
        """Before an enable in ``mode``: CSP's 0x607A is absolute (set to 0x6064, where the drive
        stands); profile and cyclic velocity act on 0x60FF, profile and cyclic torque on 0x6071 as
        they stand (set to 0); profile position and homing start only on a new set-point
        (controlword bit 4, CiA 402-2), so nothing is written for them, nor for a mode the
        toolkit does not know. In ip, ``_IP_SETTINGS`` where the drive has them: no record left
        from before is followed."""
        if mode == Mode.CSP:  # 0x607A is absolute: enabled, the drive goes for it
            self.sdo_write(cia.TARGET_POSITION, 0, int(self.sdo_read(cia.POSITION_ACTUAL)))
            return
        if mode == Mode.INTERPOLATED_POSITION:
            od = self.node.object_dictionary
            for index, sub, value, why, required in _IP_SETTINGS:
                if variable(od, (index, sub)) is not None:
                    self.setting(index, sub, value, why, required=required, then=_IP_THEN)
            return
        target = _STILL_TARGET.get(mode, 0)
        var = variable(self.node.object_dictionary, (target, 0)) if target else None
        if var is not None and var.writable:
            self.sdo_write(target, 0, 0)

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
        if int(mode) < 0 and not self.toolkit_drive:
            raise ConfigError(
                f"{self.where}: mode {int(mode)} is a manufacturer mode; not on {self.device_id.text()}"
            )
        why = f"mode {mode_text(int(mode))}"
        self.setting(cia.MODES_OF_OPERATION, 0, int(mode), why, required=True, then=self.choose())
        deadline = time.monotonic() + self.mode_timeout
        while True:
            shown = self.sdo_read(cia.MODES_DISPLAY)
            if shown == mode:
                return
            if time.monotonic() > deadline:
                raise DeviceFault(
                    f"mode {int(mode)} requested, 0x6061 still shows {shown} after {self.mode_timeout:g} s",
                    device=self.where,
                )
            self.idle()
