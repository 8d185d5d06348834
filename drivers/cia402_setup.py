"""How the host sets a CiA 402 drive up: discovery, the mode, the process data, the supervision.

``Cia402Setup`` is the set-up part of ``drivers.cia402.Cia402Axis`` (a mixin over its SDO
access): ``discover`` (0x1000, 0x1018, 0x6502 against the mode, the units of
``drivers.cia402_units``), ``set_mode`` (0x6060 written, never read; 0x6061 awaited),
``map_process_data`` (the host's mapping within the device's PDOs, or the device's own:
``drivers.cia402_pdo``), and ``configure_supervision`` (the drive's heartbeat consumer for
the host, 0x6007, 0x1017, 0x60C2 / 0x1006). It writes no manufacturer object but the toolkit
drive's own command latency, on that drive.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from drivers.cia402_pdo import Key, Pdo, disable, numbers, plan_rpdo, plan_tpdos, read_mapping, variable
from drivers.cia402_pdo import write_mapping as write_pdo
from drivers.cia402_process import ProcessData
from drivers.cia402_units import DriveUnits, discover_units
from drivers.errors import ConfigError, DeviceFault, RigError, SdoAbort
from drivers.maps import cia
from drivers.maps.cia import MODE_BITS, Mode

if TYPE_CHECKING:
    from drivers.canopen_axis import TpdoSlot

__all__ = [
    "CURRENT",
    "CW",
    "MODE_SHOWN",
    "POSITION",
    "SW",
    "TOOLKIT_DRIVE",
    "TORQUE",
    "VELOCITY",
    "Cia402Setup",
]

log = logging.getLogger(__name__)

TOOLKIT_DRIVE = (0xDB1, 0x402)  #: (vendor, product) of the toolkit's own emulated drive
SW: Key = (cia.STATUSWORD, 0)
CW: Key = (cia.CONTROLWORD, 0)
POSITION: Key = (cia.POSITION_ACTUAL, 0)
VELOCITY: Key = (cia.VELOCITY_ACTUAL, 0)
TORQUE: Key = (cia.TORQUE_ACTUAL, 0)
CURRENT: Key = (cia.CURRENT_ACTUAL, 0)
MODE_SHOWN: Key = (cia.MODES_DISPLAY, 0)
DQ_RX = [(cia.DQ_VOLTAGE, 1), (cia.DQ_VOLTAGE, 2)]
DQ_TX = [SW, (cia.FRAME_ANGLE, 0), (cia.FRAME_SPEED, 0), (cia.DQ_CURRENT, 1), (cia.DQ_CURRENT, 2)]


def interpolation_period(period: float) -> tuple[int, int]:
    """0x60C2: ``period`` [s] as (value 0-255, power of ten -128..63)."""
    for exponent in range(-6, 3):
        value = period / 10.0**exponent
        if value <= 255 and abs(value - round(value)) < 1e-6 * max(1.0, value):
            return round(value), exponent
    raise ConfigError(f"SYNC period {period!r} s cannot be written to 0x60C2 (value x 10^n, value <= 255)")


class Cia402Setup:
    """See the module docstring."""

    node: Any
    node_id: int
    name: str
    mode: str | None
    op_mode: Mode
    given_units: dict[str, float]
    units: DriveUnits
    identity: dict[str, int]
    supported_modes: frozenset[int] | None
    sync_rpdo: bool
    latency: float
    pdo: str
    #: 0x1000 named another profile (``discover``): the axis must not write CiA 402 objects
    not_a_drive: bool = False
    mode_timeout: float
    host: tuple[int, float] | None
    abort_connection: int | None
    period: float
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

    def configure_supervision(self) -> None:
        """Make the drive stop itself when the host dies, and tell it the cycle, where it can:
        its heartbeat consumer 0x1016 watches the host (``host``), 0x6007 says how it reacts,
        its producer 0x1017 beats for the host's own watch (``heartbeat_timeout``), and in the
        cyclic synchronous modes 0x60C2 / 0x1006 give the SYNC period."""
        od = self.node.object_dictionary
        if self.host is not None and cia.CONSUMER_HEARTBEAT in od:
            self._consumer_sub = self._watch_host(*self.host)
        if self.abort_connection is not None and cia.ABORT_CONNECTION_OPTION in od:
            self.sdo_write(cia.ABORT_CONNECTION_OPTION, 0, self.abort_connection)
        if self.heartbeat_timeout > 0.0 and cia.PRODUCER_HEARTBEAT in od:
            self.sdo_write(cia.PRODUCER_HEARTBEAT, 0, max(1, round(self.heartbeat_timeout / 3 * 1000)))  # ms
        if self.period > 0.0 and self.op_mode in (Mode.CSP, Mode.CSV, Mode.CST):
            if variable(od, (cia.INTERPOLATION_PERIOD, 2)) is not None:
                value, exponent = interpolation_period(self.period)
                self.sdo_write(cia.INTERPOLATION_PERIOD, 2, exponent)
                self.sdo_write(cia.INTERPOLATION_PERIOD, 1, value)
            if cia.COMM_CYCLE_PERIOD in od:
                self.sdo_write(cia.COMM_CYCLE_PERIOD, 0, round(self.period * 1e6))  # us

    def _watch_host(self, host_node: int, timeout: float) -> int | None:
        """Put (host, timeout) in the consumer entry that has the host, or a free one; its sub."""
        count = int(self.sdo_read(cia.CONSUMER_HEARTBEAT, 0))
        entries = {s: int(self.sdo_read(cia.CONSUMER_HEARTBEAT, s)) for s in range(1, count + 1)}
        sub = next((s for s, e in entries.items() if (e >> 16) & 0xFF == host_node), None)
        sub = sub or next((s for s, e in entries.items() if not e & 0xFFFF or not (e >> 16) & 0xFF), None)
        if sub is None:
            log.warning(
                "%s: no free heartbeat consumer entry (0x1016): the drive does not watch the host", self.where
            )
            return None
        self.sdo_write(cia.CONSUMER_HEARTBEAT, sub, 0)
        self.sdo_write(
            cia.CONSUMER_HEARTBEAT, sub, host_node << 16 | max(1, min(0xFFFF, round(timeout * 1000)))
        )
        return sub

    def _unwatch_host(self) -> None:
        """Disabled on purpose: the drive stops watching the host (whose heartbeat ends with the
        run; a drive that is disabled needs no watch). ``enable`` sets the watch again."""
        if self._consumer_sub is not None:
            sub, self._consumer_sub = self._consumer_sub, None
            try:
                self.sdo_write(cia.CONSUMER_HEARTBEAT, sub, 0)
            except RigError as exc:
                log.warning("%s: heartbeat consumer entry not cleared: %s", self.where, exc)

    def _optional(self, index: int, subindex: int = 0) -> Any:
        """An object the device may lack: its value, or None (absent from the EDS, or refused)."""
        if variable(self.node.object_dictionary, (index, subindex)) is None:
            return None
        try:
            return self.sdo_read(index, subindex)
        except SdoAbort:
            return None

    def discover(self, *, check_mode: bool = True) -> DriveUnits:
        """Device type and identity, supported modes (0x6502) against the mode (unless not
        ``check_mode``: commissioning, which picks its modes itself), and units."""
        device_type = self.sdo_read(cia.DEVICE_TYPE)
        if device_type & 0xFFFF != cia.PROFILE_DRIVE:
            self.not_a_drive = True  # closing writes no controlword to it (0x6040 is not ours there)
            raise ConfigError(
                f"axis {self.name!r}: node {self.node_id} is not a CiA 402 drive "
                f"(0x1000 = 0x{device_type:08X}: profile {device_type & 0xFFFF})"
            )
        self.identity = {
            k: v
            for k, sub in (("vendor", 1), ("product", 2), ("revision", 3))
            if (v := self._optional(0x1018, sub)) is not None
        }
        bits = self._optional(cia.SUPPORTED_MODES)
        if bits is not None:
            self.supported_modes = frozenset(int(m) for m, bit in MODE_BITS.items() if bits & bit)
            if check_mode and int(self.op_mode) not in self.supported_modes:
                names = ", ".join(Mode(m).name for m in sorted(self.supported_modes))
                raise ConfigError(
                    f"axis {self.name!r} (node {self.node_id}): mode {self.mode} is not in 0x6502 "
                    f"(0x{bits:08X}: {names})"
                )
        self.units = discover_units(
            self._optional,
            self.given_units,
            where=f"{self.name!r} (node {self.node_id})",
            mode=int(self.op_mode) if check_mode else 0,
        )
        return self.units

    @property
    def toolkit_drive(self) -> bool:
        """The toolkit's own emulated drive (whose manufacturer objects the host knows)."""
        return (self.identity.get("vendor"), self.identity.get("product")) == TOOLKIT_DRIVE

    def set_mode(self, mode: Mode) -> None:
        """Write 0x6060 (no read first) and wait for 0x6061 to show it, ``mode_timeout`` [s]."""
        self.sdo_write(cia.MODES_OF_OPERATION, 0, int(mode))
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

    def _wanted(self) -> tuple[list[Key], list[Key], list[Key]]:
        """(RPDO keys, TPDO keys needed, TPDO keys wanted if there is room)."""
        if self.op_mode == Mode.DQ_VOLTAGE:
            return list(DQ_RX), list(DQ_TX), []
        if self.op_mode not in cia.TARGET_OF_MODE:
            raise ConfigError(f"axis {self.name!r}: mode {self.mode} has no cyclic target")
        return [CW, cia.TARGET_OF_MODE[self.op_mode]], [SW, POSITION, VELOCITY], [MODE_SHOWN, TORQUE, CURRENT]

    def map_process_data(self) -> None:
        """Set up the PDOs (``pdo``: remap, falling back to the device's own) and ``data``."""
        od = self.node.object_dictionary
        rx_keys, needed, optional = self._wanted()
        rpdo: Pdo | None = None
        tpdos: list[Pdo] = []
        if self.pdo == "remap":
            try:
                rpdo, tpdos = self._remap(rx_keys, needed, optional)
            except SdoAbort as exc:
                log.warning(
                    '%s: the drive refused the mapping (%s); using its own (pdo = "device")', self.where, exc
                )
                self.pdo = "device"
        if self.pdo == "device":
            rpdo, tpdos = self._device_mapping(rx_keys, needed + optional)
        held = {e.key: self._held(e.key) for e in (rpdo.entries if rpdo else []) if e.key not in rx_keys}
        self.data = ProcessData(od, tpdos, rpdo, receive=self.receive_cob, read=self.sdo_read, held=held)
        for key in needed:
            if not self.data.mapped(key):
                if variable(od, key) is None or not variable(od, key).readable:
                    raise ConfigError(
                        f"{self.where}: 0x{key[0]:04X}:{key[1]:02X} is neither mapped nor readable"
                    )
                log.warning("%s: 0x%04X:%02X is in no TPDO: read by SDO every cycle", self.where, *key)
        if self.toolkit_drive and cia.COMMAND_LATENCY in od:
            self.sdo_write(cia.COMMAND_LATENCY, 0, 0 if self.sync_rpdo else round(self.latency * 1e6))
        self._measures()

    def _held(self, key: Key) -> int:
        value = self._optional(*key)
        return int(value) if value is not None else 0

    def _remap(self, rx_keys: list[Key], needed: list[Key], optional: list[Key]) -> tuple[Pdo, list[Pdo]]:
        od = self.node.object_dictionary
        rpdo = plan_rpdo(od, rx_keys, ttype=1 if self.sync_rpdo else cia.PDO_EVENT)
        tpdos, _left = plan_tpdos(od, needed + optional, ttype=1)
        write = self._pdo_write
        write_pdo(write, rpdo, node_id=self.node_id, od=od)
        for pdo in tpdos:
            write_pdo(write, pdo, node_id=self.node_id, od=od)
        used = {(True, rpdo.number)} | {(False, p.number) for p in tpdos}
        for receive in (True, False):
            for n in numbers(od, receive=receive):
                if (receive, n) not in used:
                    cob = (cia.COB_RPDO if receive else cia.COB_TPDO)[n] + self.node_id if n < 4 else 0
                    disable(write, n, receive=receive, cob_id=cob)
        return rpdo, tpdos

    def _pdo_write(self, index: int, subindex: int, value: int) -> None:
        self.sdo_write(index, subindex, value)

    def _device_mapping(self, rx_keys: list[Key], tx_keys: list[Key]) -> tuple[Pdo | None, list[Pdo]]:
        """The mapping in force: the RPDO carrying the target, the TPDOs carrying what the host
        reads (made valid and synchronous where the device lets them)."""
        od = self.node.object_dictionary
        rpdos = read_mapping(self.sdo_read, od, receive=True)
        rpdo = next((p for p in rpdos if all(k in [e.key for e in p.entries] for k in rx_keys[1:])), None)
        if rpdo is None:
            raise ConfigError(
                f"{self.where}: no RPDO of the drive carries 0x{rx_keys[-1][0]:04X} (the mode's target); "
                "its mapping cannot be changed"
            )
        self._use(rpdo, ttype=1 if self.sync_rpdo else cia.PDO_EVENT)
        tpdos = []
        for pdo in read_mapping(self.sdo_read, od, receive=False):
            if any(e.key in tx_keys for e in pdo.entries):
                self._use(pdo, ttype=1)
                tpdos.append(pdo)
        return rpdo, tpdos

    def _use(self, pdo: Pdo, *, ttype: int) -> None:
        """Make a PDO of the device's own mapping valid with transmission type ``ttype``."""
        cob = pdo.cob_id or ((cia.COB_RPDO if pdo.receive else cia.COB_TPDO)[pdo.number] + self.node_id)
        pdo.cob_id = cob
        if pdo.valid and pdo.ttype == ttype:
            return
        try:
            self.sdo_write(pdo.comm, cia.PDO_COMM_COB_ID, cob | cia.PDO_INVALID)
            self.sdo_write(pdo.comm, cia.PDO_COMM_TYPE, ttype)
            self.sdo_write(pdo.comm, cia.PDO_COMM_COB_ID, cob)
        except SdoAbort as exc:
            if not pdo.valid:
                raise ConfigError(f"{self.where}: {pdo.name} is needed but cannot be enabled: {exc}") from exc
            log.warning("%s: %s keeps its transmission type %d: %s", self.where, pdo.name, pdo.ttype, exc)
            return
        pdo.ttype, pdo.valid = ttype, True

    def _measures(self) -> None:
        data = self.data
        assert data is not None
        if self.op_mode == Mode.DQ_VOLTAGE:
            self.measures = frozenset({"position", "velocity", "current"})
            return
        u = self.units
        self.measures = frozenset(
            {"position", "velocity"}
            | ({"torque"} if math.isfinite(u.rated_torque) and data.mapped(TORQUE) else set())
            | ({"current"} if math.isfinite(u.rated_current) and data.mapped(CURRENT) else set())
        )
        self._motion = data.slot_of(POSITION)
