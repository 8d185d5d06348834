"""How the host sets up a CiA 402 drive's process data: its own mapping within the drive's PDOs, or
the drive's.

``Cia402Mapping`` is the PDO part of ``drivers.cia402_setup.Cia402Setup``: ``map_process_data``
writes a mapping that fits the device (``drivers.cia402_pdo``) by the CiA 301 protocol where the
EDS declares the mapping writable, and otherwise (or when the drive refuses) takes the drive's
own, made valid and synchronous where its EDS lets it. An RPDO of the drive's own that carries a
manufacturer object beside the target would write that object every cycle: on any drive but the
toolkit's own it is refused for cyclic use, naming the object. Frames are decoded from the
mapping in force (``drivers.cia402_process``).

``maps`` (``FEEDBACK`` by default) chooses what the TPDOs carry beside the statusword and the
position (where the drive has one: a speed controller without 0x6064 is read by its 0x606C):
the velocity 0x606C (needed where chosen), the mode shown 0x6061, the torque 0x6077
and the current 0x6078 (where there is room). A lean image (``maps = {"position"}``: one TPDO
of statusword and position, 6 bytes) leaves a fast loop's bus its room: the velocity is then
the position's backward difference (``drivers.cia402``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from drivers.cia402_pdo import Key, Pdo, disable, plan_rpdo, plan_tpdos, read_mapping, share, variable
from drivers.cia402_pdo import write_mapping as write_pdo
from drivers.cia402_process import ProcessData
from drivers.cia402_units import DriveUnits
from drivers.errors import ConfigError, SdoAbort
from drivers.identity import Identity
from drivers.maps import cia
from drivers.maps.cia import Controlword, Mode

if TYPE_CHECKING:
    from drivers.canopen_axis import TpdoSlot

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
    "Cia402Mapping",
    "CyclePlan",
]

log = logging.getLogger(__name__)

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


class Cia402Mapping:
    """See the module docstring (a mixin of ``Cia402Setup``)."""

    node: Any
    node_id: int
    name: str
    mode: str | None
    op_mode: Mode
    units: DriveUnits
    device_id: Identity
    sync_rpdo: bool
    latency: float
    pdo: str
    axis_number: int
    maps: frozenset[str]
    has_position: bool
    data: ProcessData | None
    measures: frozenset[str]
    _motion: TpdoSlot | None
    _plan: CyclePlan

    if TYPE_CHECKING:  # the axis's own, used here

        @property
        def where(self) -> str: ...
        @property
        def toolkit_drive(self) -> bool: ...
        def sdo_read(self, index: int, subindex: int = 0) -> Any: ...
        def sdo_write(self, index: int, subindex: int, value: Any) -> None: ...
        def receive_cob(self, cob_id: int, codec: Any) -> TpdoSlot: ...
        def _optional(self, index: int, subindex: int = 0) -> Any: ...
        def setting(
            self, index: int, subindex: int, value: Any, why: str, *, required: bool = False, then: str = ""
        ) -> bool: ...

    @property
    def reads_velocity(self) -> bool:
        """0x606C is read: where chosen (``maps``), and always on a drive without a position."""
        return "velocity" in self.maps or not self.has_position

    def _wanted(self) -> tuple[list[Key], list[Key], list[Key]]:
        """(RPDO keys, TPDO keys needed, TPDO keys wanted if there is room)."""
        if self.op_mode == Mode.DQ_VOLTAGE:
            return list(DQ_RX), list(DQ_TX), []
        if self.op_mode not in cia.TARGET_OF_MODE:
            raise ConfigError(f"axis {self.name!r}: mode {self.mode} has no cyclic target")
        needed = [SW] + [POSITION] * self.has_position + [VELOCITY] * self.reads_velocity
        optional = [FEEDBACK[name] for name in ("mode", "torque", "current") if name in self.maps]
        return [CW, cia.TARGET_OF_MODE[self.op_mode]], needed, optional

    def map_process_data(self) -> None:
        """Set up the PDOs (``pdo``: remap, falling back to the device's own) and ``data``.

        Raises
        ------
        ConfigError
            A needed object is neither mapped nor readable, or the device's mapping cannot serve.
        """
        od = self.node.object_dictionary
        rx_keys, needed, optional = self._wanted()
        rpdo: Pdo | None = None
        tpdos: list[Pdo] = []
        fixed = self._fixed_mapping(rx_keys, needed + optional) if self.pdo == "remap" else None
        if fixed is not None:
            log.warning(
                '%s: the drive\'s PDO mapping is fixed (%s); using its own (pdo = "device")',
                self.where,
                fixed,
            )
            self.pdo = "device"
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
            latency = 0 if self.sync_rpdo else round(self.latency * 1e6)
            self.setting(cia.COMMAND_LATENCY, 0, latency, "the command latency [us]")
        self._measures()

    def _fixed_mapping(self, rx_keys: list[Key], tx_keys: list[Key]) -> str | None:
        """Why the mapping the host would write cannot be written (a mapping entry the EDS declares
        read-only or constant), or None."""
        od = self.node.object_dictionary
        rpdo = plan_rpdo(od, rx_keys, ttype=1)
        tpdos, _left = plan_tpdos(od, tx_keys, ttype=1)
        for pdo in (rpdo, *tpdos):
            for key in ((pdo.mapping, 0), (pdo.mapping, 1), (pdo.comm, cia.PDO_COMM_COB_ID)):
                var = variable(od, key)
                if var is not None and not var.writable:
                    return f"0x{key[0]:04X}:{key[1]:02X} is {var.access_type} in its EDS"
        return None

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
            for n in share(od, receive=receive):  # an axis of several leaves the others' PDOs alone
                if (receive, n) not in used:
                    cob = (cia.COB_RPDO if receive else cia.COB_TPDO)[n] + self.node_id if n < 4 else 0
                    disable(self._disable_write, n, receive=receive, cob_id=cob)
        return rpdo, tpdos

    def _pdo_write(self, index: int, subindex: int, value: int) -> None:
        self.sdo_write(index, subindex, value)

    def _disable_write(self, index: int, subindex: int, value: int) -> None:
        """A PDO the host does not use is made invalid where the EDS lets its COB-ID be written."""
        var = variable(self.node.object_dictionary, (index, subindex))
        if var is not None and not var.writable:
            log.debug(
                "%s: 0x%04X:%02X is %s: the PDO is left as it is",
                self.where,
                index,
                subindex,
                var.access_type,
            )
            return
        self.sdo_write(index, subindex, value)

    def _device_mapping(self, rx_keys: list[Key], tx_keys: list[Key]) -> tuple[Pdo | None, list[Pdo]]:
        """The mapping in force: the RPDO carrying the target, the TPDOs carrying what the host
        reads (made valid and synchronous where the device lets them)."""
        od = self.node.object_dictionary
        rpdo = self._target_rpdo(read_mapping(self.sdo_read, od, receive=True), rx_keys)
        self._use(rpdo, ttype=1 if self.sync_rpdo else cia.PDO_EVENT)
        tpdos = []
        for pdo in read_mapping(self.sdo_read, od, receive=False):
            if any(e.mine and e.key in tx_keys for e in pdo.entries):
                self._use(pdo, ttype=1)
                tpdos.append(pdo)
        return rpdo, tpdos

    def refuse_foreign_rpdo(self) -> None:
        """Before anything is written: where the drive's own mapping will be used (``pdo =
        "device"``, or a mapping its EDS declares fixed), its RPDO that carries the target is read
        (SDO uploads) and a manufacturer object in it refuses the drive (``_target_rpdo``)."""
        rx_keys, needed, optional = self._wanted()
        if self.pdo == "remap" and self._fixed_mapping(rx_keys, needed + optional) is None:
            return
        self._target_rpdo(read_mapping(self.sdo_read, self.node.object_dictionary, receive=True), rx_keys)

    def _target_rpdo(self, rpdos: list[Pdo], rx_keys: list[Key]) -> Pdo:
        """Of the drive's own RPDOs, the one that carries the target with the fewest manufacturer
        objects beside it; ConfigError where none carries it, or where it carries one (on any drive
        but the toolkit's the host would write that object every cycle)."""
        od = self.node.object_dictionary
        carrying = [p for p in rpdos if all(k in [e.key for e in p.entries if e.mine] for k in rx_keys[1:])]
        if not carrying:
            raise ConfigError(
                f"{self.where}: no RPDO of the drive carries 0x{rx_keys[-1][0]:04X} (the mode's target); "
                "its mapping cannot be changed"
            )
        rpdo = min(carrying, key=lambda p: len(self._foreign_entries(p)))
        foreign = self._foreign_entries(rpdo)
        if foreign:
            e = foreign[0]
            wire = e.wire(self.axis_number)
            var = variable(od, e.key) if e.mine else None
            name = f" ({var.name})" if var is not None else ""
            whose = (
                f"an object of the device's axis {e.axis} (its 0x{e.index:04X})"
                if e.axis
                else f"a manufacturer object of {self.device_id.text()}"
            )
            raise ConfigError(
                f"{self.where}: the drive's own {rpdo.name}, which carries the mode's target, also carries "
                f"0x{wire:04X}:{e.subindex:02X}{name}, {whose}; its mapping cannot be changed, and the host "
                "would write that object every cycle: the drive is refused for cyclic use (rig drive still "
                f"commissions it by SDO; map that RPDO without 0x{wire:04X} with the vendor's tool, then run)"
            )
        return rpdo

    def _foreign_entries(self, pdo: Pdo) -> list[Any]:
        """The entries of ``pdo`` the host must not write every cycle: another axis's objects (on a
        drive of several), manufacturer objects of a drive not the toolkit's."""
        return [
            e for e in pdo.entries if e.axis or (e.index in cia.MANUFACTURER_AREA and not self.toolkit_drive)
        ]

    def _use(self, pdo: Pdo, *, ttype: int) -> None:
        """Make a PDO of the device's own mapping valid with transmission type ``ttype``."""
        cob = pdo.cob_id or ((cia.COB_RPDO if pdo.receive else cia.COB_TPDO)[pdo.number] + self.node_id)
        pdo.cob_id = cob
        if pdo.valid and pdo.ttype == ttype:
            return
        od = self.node.object_dictionary
        fixed = [
            f"0x{pdo.comm:04X}:{sub:02X} is {var.access_type}"
            for sub in (cia.PDO_COMM_COB_ID, cia.PDO_COMM_TYPE)
            if (var := variable(od, (pdo.comm, sub))) is not None and not var.writable
        ]
        if fixed:
            if not pdo.valid:
                raise ConfigError(
                    f"{self.where}: {pdo.name} is needed but cannot be enabled: {', '.join(fixed)}"
                )
            log.warning(
                "%s: %s keeps its transmission type %d: %s", self.where, pdo.name, pdo.ttype, fixed[0]
            )
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
        """What the feedback measures, the slot whose stamp is the sample's, and the cycle's plan
        (``CyclePlan``), once for the mapping in force."""
        data = self.data
        assert data is not None
        if self.op_mode == Mode.DQ_VOLTAGE:
            self.measures = frozenset({"position", "velocity", "current"})
        else:
            u = self.units
            self.measures = frozenset(
                {"velocity"}
                | ({"position"} if self.has_position else set())
                | ({"torque"} if math.isfinite(u.rated_torque) and data.mapped(TORQUE) else set())
                | ({"current"} if math.isfinite(u.rated_current) and data.mapped(CURRENT) else set())
            )
            self._motion = data.slot_of(POSITION if self.has_position else VELOCITY)
        self._plan = CyclePlan(data, self.measures, self.op_mode, velocity=self.reads_velocity)
