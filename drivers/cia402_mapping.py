"""How the host sets up a CiA 402 drive's process data: its own mapping within the drive's PDOs, or
the drive's.

``Cia402Mapping`` is a part of ``drivers.cia402.Cia402Axis``, called from its set-up: ``map_process_data``
writes a mapping that fits the device (``drivers.cia402_pdo``) by the CiA 301 protocol where the
EDS declares the mapping writable, and otherwise (or when the drive refuses) takes the drive's
own, made valid and synchronous where its EDS lets it. An RPDO of the drive's own that carries a
manufacturer object beside the target would write that object every cycle: on any drive but the
toolkit's own it is refused for cyclic use, naming the object. Frames are decoded from the
mapping in force (``drivers.cia402_process``), and the cycle's plan is made for it once
(``CyclePlan``): the part gives them to its axis (``Mapped``). It owns its choice (``pdo``); what
it needs of its axis is ``MappedAxis``.

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
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

from drivers.cia402_pdo import Key, Pdo, disable, plan_rpdo, plan_tpdos, read_mapping, share, variable
from drivers.cia402_pdo import write_mapping as write_pdo
from drivers.cia402_plan import (
    CURRENT,
    CW,
    DQ_RX,
    DQ_TX,
    FEEDBACK,
    MODE_SHOWN,
    POSITION,
    SW,
    TORQUE,
    VELOCITY,
    CyclePlan,
    SdoAxis,
)
from drivers.cia402_process import ProcessData
from drivers.cia402_units import DriveUnits
from drivers.errors import ConfigError, SdoAbort
from drivers.identity import Identity
from drivers.maps import cia
from drivers.maps.cia import Mode
from drivers.tpdo_receiver import TpdoReceiver
from drivers.tpdo_slot import TpdoSlot

if TYPE_CHECKING:
    from drivers.cia402_discovery import Cia402Discovery
    from drivers.cia402_setup import Cia402Setup

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
    "Mapped",
]

log = logging.getLogger(__name__)


class Mapped(NamedTuple):
    """What set-up's mapping gives the cycle (``Cia402Mapping.map_process_data``)."""

    data: ProcessData  #: the process data in force
    measures: frozenset[str]  #: what the feedback measures
    motion: TpdoSlot | None  #: the slot whose stamp is the sample's
    plan: CyclePlan  #: what each cycle reads and packs


class MappedAxis(SdoAxis, Protocol):
    """What the mapping needs of its axis (``drivers.cia402.Cia402Axis``): its node, mode and
    units, what it is (``discovery``), its SDO access, its settings and its TPDOs."""

    node: Any
    node_id: int
    name: str
    mode: str | None
    op_mode: Mode
    units: DriveUnits
    device_id: Identity
    axis_number: int
    maps: frozenset[str]  #: what the TPDOs carry (``drivers.cia402_feedback``)
    discovery: Cia402Discovery
    settings: Cia402Setup
    tpdos: TpdoReceiver  #: the TPDOs it receives (``receive_cob``)


class Cia402Mapping:
    """The process data of a CiA 402 drive, mapped at set-up (see the module docstring).

    Parameters
    ----------
    axis : MappedAxis
        The axis it maps.
    pdo : str
        "remap" (a mapping that fits the device, else the device's own) or "device" (its own).
    sync_rpdo : bool
        The RPDO acts at the next SYNC (one period of delay), else on receipt.
    latency : float
        [s] the toolkit's own drive acts on an RPDO this late, where not ``sync_rpdo``.
    """

    def __init__(self, axis: MappedAxis, pdo: str, *, sync_rpdo: bool, latency: float) -> None:
        self.axis = axis
        self.pdo = pdo  #: "remap" or "device": "device" once the drive refused or fixed its mapping
        self.sync_rpdo, self.latency = sync_rpdo, latency

    @property
    def reads_velocity(self) -> bool:
        """0x606C is read: where chosen (``maps``), and always on a drive without a position."""
        return "velocity" in self.axis.maps or not self.axis.discovery.has_position

    def _wanted(self) -> tuple[list[Key], list[Key], list[Key]]:
        """(RPDO keys, TPDO keys needed, TPDO keys wanted if there is room)."""
        if self.axis.op_mode == Mode.DQ_VOLTAGE:
            return list(DQ_RX), list(DQ_TX), []
        if self.axis.op_mode not in cia.TARGET_OF_MODE:
            raise ConfigError(f"axis {self.axis.name!r}: mode {self.axis.mode} has no cyclic target")
        needed = [SW] + [POSITION] * self.axis.discovery.has_position + [VELOCITY] * self.reads_velocity
        optional = [FEEDBACK[name] for name in ("mode", "torque", "current") if name in self.axis.maps]
        return [CW, cia.TARGET_OF_MODE[self.axis.op_mode]], needed, optional

    def map_process_data(self) -> Mapped:
        """Set up the PDOs (``pdo``: remap, falling back to the device's own) and the process data.

        Returns
        -------
        Mapped
            The process data in force, what the feedback measures, the sample's slot, the plan.

        Raises
        ------
        ConfigError
            A needed object is neither mapped nor readable, or the device's mapping cannot serve.
        """
        od = self.axis.node.object_dictionary
        rx_keys, needed, optional = self._wanted()
        rpdo: Pdo | None = None
        tpdos: list[Pdo] = []
        fixed = self._fixed_mapping(rx_keys, needed + optional) if self.pdo == "remap" else None
        if fixed is not None:
            log.warning(
                '%s: the drive\'s PDO mapping is fixed (%s); using its own (pdo = "device")',
                self.axis.where,
                fixed,
            )
            self.pdo = "device"
        if self.pdo == "remap":
            try:
                rpdo, tpdos = self._remap(rx_keys, needed, optional)
            except SdoAbort as exc:
                log.warning(
                    '%s: the drive refused the mapping (%s); using its own (pdo = "device")',
                    self.axis.where,
                    exc,
                )
                self.pdo = "device"
        if self.pdo == "device":
            rpdo, tpdos = self._device_mapping(rx_keys, needed + optional)
        held = {e.key: self._held(e.key) for e in (rpdo.entries if rpdo else []) if e.key not in rx_keys}
        data = ProcessData(
            od, tpdos, rpdo, receive=self.axis.tpdos.receive_cob, read=self.axis.sdo_read, held=held
        )
        for key in needed:
            if not data.mapped(key):
                if variable(od, key) is None or not variable(od, key).readable:
                    raise ConfigError(
                        f"{self.axis.where}: 0x{key[0]:04X}:{key[1]:02X} is neither mapped nor readable"
                    )
                log.warning("%s: 0x%04X:%02X is in no TPDO: read by SDO every cycle", self.axis.where, *key)
        if self.axis.toolkit_drive and cia.COMMAND_LATENCY in od:
            latency = 0 if self.sync_rpdo else round(self.latency * 1e6)
            self.axis.settings.setting(cia.COMMAND_LATENCY, 0, latency, "the command latency [us]")
        return self._measures(data)

    def _fixed_mapping(self, rx_keys: list[Key], tx_keys: list[Key]) -> str | None:
        """Why the mapping the host would write cannot be written (a mapping entry the EDS declares
        read-only or constant), or None."""
        od = self.axis.node.object_dictionary
        rpdo = plan_rpdo(od, rx_keys, ttype=1)
        tpdos, _left = plan_tpdos(od, tx_keys, ttype=1)
        for pdo in (rpdo, *tpdos):
            for key in ((pdo.mapping, 0), (pdo.mapping, 1), (pdo.comm, cia.PDO_COMM_COB_ID)):
                var = variable(od, key)
                if var is not None and not var.writable:
                    return f"0x{key[0]:04X}:{key[1]:02X} is {var.access_type} in its EDS"
        return None

    def _held(self, key: Key) -> int:
        value = self.axis.discovery.optional(*key)
        return int(value) if value is not None else 0

    def _remap(self, rx_keys: list[Key], needed: list[Key], optional: list[Key]) -> tuple[Pdo, list[Pdo]]:
        od = self.axis.node.object_dictionary
        rpdo = plan_rpdo(od, rx_keys, ttype=1 if self.sync_rpdo else cia.PDO_EVENT)
        tpdos, _left = plan_tpdos(od, needed + optional, ttype=1)
        write = self._pdo_write
        write_pdo(write, rpdo, node_id=self.axis.node_id, od=od)
        for pdo in tpdos:
            write_pdo(write, pdo, node_id=self.axis.node_id, od=od)
        used = {(True, rpdo.number)} | {(False, p.number) for p in tpdos}
        for receive in (True, False):
            for n in share(od, receive=receive):  # an axis of several leaves the others' PDOs alone
                if (receive, n) not in used:
                    cob = (cia.COB_RPDO if receive else cia.COB_TPDO)[n] + self.axis.node_id if n < 4 else 0
                    disable(self._disable_write, n, receive=receive, cob_id=cob)
        return rpdo, tpdos

    def _pdo_write(self, index: int, subindex: int, value: int) -> None:
        self.axis.sdo_write(index, subindex, value)

    def _disable_write(self, index: int, subindex: int, value: int) -> None:
        """A PDO the host does not use is made invalid where the EDS lets its COB-ID be written."""
        var = variable(self.axis.node.object_dictionary, (index, subindex))
        if var is not None and not var.writable:
            log.debug(
                "%s: 0x%04X:%02X is %s: the PDO is left as it is",
                self.axis.where,
                index,
                subindex,
                var.access_type,
            )
            return
        self.axis.sdo_write(index, subindex, value)

    def _device_mapping(self, rx_keys: list[Key], tx_keys: list[Key]) -> tuple[Pdo | None, list[Pdo]]:
        """The mapping in force: the RPDO carrying the target, the TPDOs carrying what the host
        reads (made valid and synchronous where the device lets them)."""
        od = self.axis.node.object_dictionary
        rpdo = self._target_rpdo(read_mapping(self.axis.sdo_read, od, receive=True), rx_keys)
        self._use(rpdo, ttype=1 if self.sync_rpdo else cia.PDO_EVENT)
        tpdos = []
        for pdo in read_mapping(self.axis.sdo_read, od, receive=False):
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
        self._target_rpdo(
            read_mapping(self.axis.sdo_read, self.axis.node.object_dictionary, receive=True), rx_keys
        )

    def _target_rpdo(self, rpdos: list[Pdo], rx_keys: list[Key]) -> Pdo:
        """Of the drive's own RPDOs, the one that carries the target with the fewest manufacturer
        objects beside it; ConfigError where none carries it, or where it carries one (on any drive
        but the toolkit's the host would write that object every cycle)."""
        od = self.axis.node.object_dictionary
        carrying = [p for p in rpdos if all(k in [e.key for e in p.entries if e.mine] for k in rx_keys[1:])]
        if not carrying:
            raise ConfigError(
                f"{self.axis.where}: no RPDO of the drive carries 0x{rx_keys[-1][0]:04X} (the mode's "
                "target); its mapping cannot be changed"
            )
        rpdo = min(carrying, key=lambda p: len(self._foreign_entries(p)))
        foreign = self._foreign_entries(rpdo)
        if foreign:
            e = foreign[0]
            wire = e.wire(self.axis.axis_number)
            var = variable(od, e.key) if e.mine else None
            name = f" ({var.name})" if var is not None else ""
            whose = (
                f"an object of the device's axis {e.axis} (its 0x{e.index:04X})"
                if e.axis
                else f"a manufacturer object of {self.axis.device_id.text()}"
            )
            raise ConfigError(
                f"{self.axis.where}: the drive's own {rpdo.name}, which carries the mode's target, also "
                f"carries 0x{wire:04X}:{e.subindex:02X}{name}, {whose}; its mapping cannot be changed, "
                "and the host would write that object every cycle: the drive is refused for cyclic use "
                "(rig drive still commissions it by SDO; map that RPDO without "
                f"0x{wire:04X} with the vendor's tool, then run)"
            )
        return rpdo

    def _foreign_entries(self, pdo: Pdo) -> list[Any]:
        """The entries of ``pdo`` the host must not write every cycle: another axis's objects (on a
        drive of several), manufacturer objects of a drive not the toolkit's."""
        return [
            e
            for e in pdo.entries
            if e.axis or (e.index in cia.MANUFACTURER_AREA and not self.axis.toolkit_drive)
        ]

    def _use(self, pdo: Pdo, *, ttype: int) -> None:
        """Make a PDO of the device's own mapping valid with transmission type ``ttype``."""
        cob = pdo.cob_id or ((cia.COB_RPDO if pdo.receive else cia.COB_TPDO)[pdo.number] + self.axis.node_id)
        pdo.cob_id = cob
        if pdo.valid and pdo.ttype == ttype:
            return
        od = self.axis.node.object_dictionary
        fixed = [
            f"0x{pdo.comm:04X}:{sub:02X} is {var.access_type}"
            for sub in (cia.PDO_COMM_COB_ID, cia.PDO_COMM_TYPE)
            if (var := variable(od, (pdo.comm, sub))) is not None and not var.writable
        ]
        if fixed:
            if not pdo.valid:
                raise ConfigError(
                    f"{self.axis.where}: {pdo.name} is needed but cannot be enabled: {', '.join(fixed)}"
                )
            log.warning(
                "%s: %s keeps its transmission type %d: %s", self.axis.where, pdo.name, pdo.ttype, fixed[0]
            )
            return
        try:
            self.axis.sdo_write(pdo.comm, cia.PDO_COMM_COB_ID, cob | cia.PDO_INVALID)
            self.axis.sdo_write(pdo.comm, cia.PDO_COMM_TYPE, ttype)
            self.axis.sdo_write(pdo.comm, cia.PDO_COMM_COB_ID, cob)
        except SdoAbort as exc:
            if not pdo.valid:
                raise ConfigError(
                    f"{self.axis.where}: {pdo.name} is needed but cannot be enabled: {exc}"
                ) from exc
            log.warning(
                "%s: %s keeps its transmission type %d: %s", self.axis.where, pdo.name, pdo.ttype, exc
            )
            return
        pdo.ttype, pdo.valid = ttype, True

    def _measures(self, data: ProcessData) -> Mapped:
        """What the feedback measures, the slot whose stamp is the sample's, and the cycle's plan
        (``CyclePlan``), once for the mapping in force (``data``)."""
        motion = None
        if self.axis.op_mode == Mode.DQ_VOLTAGE:
            measures = frozenset({"position", "velocity", "current"})
        else:
            u = self.axis.units
            measures = frozenset(
                {"velocity"}
                | ({"position"} if self.axis.discovery.has_position else set())
                | ({"torque"} if math.isfinite(u.rated_torque) and data.mapped(TORQUE) else set())
                | ({"current"} if math.isfinite(u.rated_current) and data.mapped(CURRENT) else set())
            )
            motion = data.slot_of(POSITION if self.axis.discovery.has_position else VELOCITY)
        plan = CyclePlan(data, measures, self.axis.op_mode, velocity=self.reads_velocity)
        return Mapped(data, measures, motion, plan)
