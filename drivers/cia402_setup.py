"""How the host sets a CiA 402 drive up: discovery, the mode, the process data, the supervision.

``Cia402Setup`` is the set-up part of ``drivers.cia402.Cia402Axis`` (a mixin over its SDO
access): ``discover`` (``drivers.cia402_discovery``: 0x1000 and the axis, 0x1018, 0x6502 against
the mode, the units of ``drivers.cia402_units``), ``set_mode`` (0x6060 written, never read; 0x6061 awaited),
``map_process_data`` (``drivers.cia402_mapping``), and ``configure_supervision`` (the drive's
heartbeat consumer for the host, 0x6007, 0x1017, 0x60C2 / 0x1006), and before each enable the
target the mode acts on as it stands (``_hold_still``). It writes no manufacturer
object and uses no manufacturer mode but on the toolkit's own drive (``toolkit_drive``, by
0x1018), and only entries the EDS declares writable (``drivers.cia402_access.Setting``).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from drivers.cia402_access import Setting, period_text
from drivers.cia402_access import interpolation_period as interpolation_setting
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
from drivers.errors import ConfigError, DeviceFault, RigError
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
    host: tuple[int, float] | None
    abort_connection: int | None
    period: float
    rpdo_deadline: float
    _deadline_comm: int | None
    heartbeat_timeout: float
    data: ProcessData | None
    measures: frozenset[str]
    idle: Callable[[], None]
    _consumer_sub: int | None
    _motion: TpdoSlot | None

    if TYPE_CHECKING:  # the axis's own, used here

        @property
        def where(self) -> str: ...
        def sdo_read(self, index: int, subindex: int = 0) -> Any: ...
        def sdo_write(self, index: int, subindex: int, value: Any) -> None: ...
        def receive_cob(self, cob_id: int, codec: Any) -> TpdoSlot: ...
        def sdo_upload(self, index: int, subindex: int = 0) -> bytes: ...
        def check_identity(self, *, give: str) -> Identity: ...
        def siblings(self) -> list[Any]: ...

    def configure_supervision(self) -> None:
        """Make the drive stop itself when the host dies, and tell it the cycle, where it can:
        its heartbeat consumer 0x1016 watches the host (``host``), 0x6007 says how it reacts,
        its producer 0x1017 beats for the host's own watch (``heartbeat_timeout``), and in the
        cyclic synchronous modes 0x60C2 / 0x1006 give the SYNC period. Each is optional: an
        entry the drive declares read-only is read, not written, and a refusal is one warning."""
        od = self.node.object_dictionary
        if self.host is not None and cia.CONSUMER_HEARTBEAT in od:
            self._consumer_sub = self._watch_host(*self.host)
        elif self.host is not None:
            log.warning(
                "%s: the drive has no heartbeat consumer (0x1016): it cannot watch the host's heartbeat "
                "and will not stop itself if the host dies; give it another stop (a safety circuit)",
                self.where,
            )
        if self.abort_connection is not None and cia.ABORT_CONNECTION_OPTION in od:
            self._setting(
                cia.ABORT_CONNECTION_OPTION, 0, self.abort_connection, "the reaction to a lost host"
            )
        if self.heartbeat_timeout > 0.0 and cia.PRODUCER_HEARTBEAT in od:
            beat = max(1, round(self.heartbeat_timeout / 3 * 1000))  # ms
            self._setting(cia.PRODUCER_HEARTBEAT, 0, beat, "the drive's heartbeat the host watches")
        if self.period > 0.0 and self.op_mode in (Mode.CSP, Mode.INTERPOLATED_POSITION, Mode.CSV, Mode.CST):
            if variable(od, (cia.INTERPOLATION_PERIOD, 1)) is not None:
                self._interpolation_period()
            if cia.COMM_CYCLE_PERIOD in od:
                self._setting(cia.COMM_CYCLE_PERIOD, 0, round(self.period * 1e6), "the SYNC period [us]")

    def _setting(
        self, index: int, subindex: int, value: Any, why: str, *, required: bool = False, then: str = ""
    ) -> bool:
        """``drivers.cia402_access.Setting``: written where the EDS declares it writable."""
        setting = Setting(index, subindex, value, why, required, then)
        return setting.apply(self.node.object_dictionary, self.sdo_read, self.sdo_write, self.where)

    def _interpolation_period(self) -> None:
        """0x60C2 = the SYNC period, in the drive's own exponent (sub 2) where it can be given in
        it; a warning naming the period in force where it cannot."""
        od = self.node.object_dictionary
        sub2 = variable(od, (cia.INTERPOLATION_PERIOD, 2))
        exponent = self._optional(cia.INTERPOLATION_PERIOD, 2) if sub2 is not None and sub2.readable else None
        writable = sub2 is not None and sub2.writable
        value, new_exponent, in_force = interpolation_setting(
            self.period, None if exponent is None else int(exponent), writable
        )
        why = f"the SYNC period {period_text(self.period)}"
        if new_exponent is not None and not self._setting(cia.INTERPOLATION_PERIOD, 2, new_exponent, why):
            return
        if not self._setting(cia.INTERPOLATION_PERIOD, 1, value, why):
            return
        if abs(in_force - self.period) > 1e-9 * self.period:
            log.warning(
                "%s: the SYNC period %s cannot be given in the drive's interpolation time index "
                "(0x60C2:02 = %s, %s in the EDS): 0x60C2 = %d x 10^%s s, the drive interpolates over %s",
                self.where,
                period_text(self.period),
                exponent,
                getattr(sub2, "access_type", "?"),
                value,
                exponent,
                period_text(in_force),
            )

    def _watch_host(self, host_node: int, timeout: float) -> int | None:
        """Put (host, timeout) in the consumer entry that has the host, or a free one; its sub."""
        count = int(self.sdo_read(cia.CONSUMER_HEARTBEAT, 0))
        entries = {s: int(self.sdo_read(cia.CONSUMER_HEARTBEAT, s)) for s in range(1, count + 1)}
        sub = next((s for s, e in entries.items() if (e >> 16) & 0xFF == host_node), None)
        sub = sub or next((s for s, e in entries.items() if not e & 0xFFFF or not (e >> 16) & 0xFF), None)
        if sub is None:
            taken = ", ".join(
                f"0x1016:{s:02X} node {(e >> 16) & 0xFF} ({e & 0xFFFF} ms)" for s, e in entries.items()
            )
            log.warning(
                "%s: no free heartbeat consumer entry (%s): the drive does not watch the host and will not "
                "stop itself if it dies; where that watch is not needed, free its entry (rig drive sdo write "
                "0x1016:NN 0)",
                self.where,
                taken or "0x1016 has none",
            )
            return None
        entry = host_node << 16 | max(1, min(0xFFFF, round(timeout * 1000)))
        if entries[sub] == entry:
            return sub
        why = "the drive's watch of the host's heartbeat"
        if entries[sub] and not self._setting(cia.CONSUMER_HEARTBEAT, sub, 0, why):
            return None
        return sub if self._setting(cia.CONSUMER_HEARTBEAT, sub, entry, why) else None

    def _unwatch_host(self) -> None:
        """Disabled on purpose, and confirmed (``disable``): the drive stops watching the host
        (whose heartbeat ends with the run; a disabled drive needs no watch); an entry not cleared
        stays the axis's (a warning). ``enable`` sets the watch again. On a drive of several axes
        the entry is the node's: the last of its axes to be disabled clears it, never one while
        another may still be enabled."""
        sub = self._consumer_sub
        if sub is not None and any(getattr(a, "_consumer_sub", None) == sub for a in self.siblings()):
            self._consumer_sub = None  # another axis of the node still holds the watch
            return
        if sub is not None:
            try:
                self.sdo_write(cia.CONSUMER_HEARTBEAT, sub, 0)
            except RigError as exc:
                log.warning("%s: heartbeat consumer entry not cleared: %s", self.where, exc)
                return
            self._consumer_sub = None

    def _watch_commands(self) -> None:
        """The toolkit's own drive: the deadline of its command RPDO, that RPDO's event timer
        (CiA 301 0x1400+n sub 5, which on an RPDO is its deadline: no RPDO within it, EMCY 0x8250
        and the drive's reaction 0x6007) at ``rpdo_deadline`` [s], rounded up to whole ms, so
        that a host that stops sending (dead, frozen) has the drive stop itself within a few
        periods, not at its heartbeat's 0.3 s. A confirmed ``disable`` lifts it."""
        data = self.data
        rpdo = data.rpdo if data is not None else None
        if not (self.rpdo_deadline > 0.0 and rpdo is not None and self.toolkit_drive):
            return
        ms = max(1, math.ceil(self.rpdo_deadline * 1000.0 - 1e-9))
        why = "the deadline of the commands [ms]"
        if self._setting(rpdo.comm, cia.PDO_COMM_EVENT_TIMER, ms, why):
            self._deadline_comm = rpdo.comm

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
                    self._setting(index, sub, value, why, required=required, then=_IP_THEN)
            return
        target = _STILL_TARGET.get(mode, 0)
        var = variable(self.node.object_dictionary, (target, 0)) if target else None
        if var is not None and var.writable:
            self.sdo_write(target, 0, 0)

    def _unwatch_commands(self) -> None:
        """Disabled on purpose, and confirmed (``disable``): the drive's deadline on the commands
        is lifted; one not lifted stays the axis's (a warning: the stop's RPDOs go on meanwhile)."""
        comm = self._deadline_comm
        if comm is not None:
            try:
                self.sdo_write(comm, cia.PDO_COMM_EVENT_TIMER, 0)
            except RigError as exc:
                log.warning("%s: the commands' deadline (0x%04X:05) not lifted: %s", self.where, comm, exc)
                return
            self._deadline_comm = None

    def set_mode(self, mode: Mode) -> None:
        """Write 0x6060 (no read first) and wait for 0x6061 to show it, ``mode_timeout`` [s]; a
        manufacturer mode only on the toolkit's own drive."""
        if int(mode) < 0 and not self.toolkit_drive:
            raise ConfigError(
                f"{self.where}: mode {int(mode)} is a manufacturer mode; not on {self.device_id.text()}"
            )
        why = f"mode {mode_text(int(mode))}"
        self._setting(cia.MODES_OF_OPERATION, 0, int(mode), why, required=True, then=self.choose())
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
