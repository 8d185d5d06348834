"""Host-side CiA 402 drive: an ``AxisDriver`` on canopen's ``RemoteNode`` that adapts to the device.

It builds on ``RemoteNode`` (SDO client, NMT, EMCY consumer), not on ``BaseNode402``:
BaseNode402's fault reset always waits about 400 ms (canopen #261), it asserts on the NMT
state (#309), and a controlword mapped in a synchronous RPDO is only buffered until that
RPDO is transmitted. Here the controlword goes by SDO during state changes, and the host
loop transmits the RPDO once per cycle.

Set-up takes the drive as it is (``setup``):

- its identity (0x1000 must be a CiA 402 device, 0x1018) and modes (0x6502 where it has
  one: the configured mode must be there before 0x6060 is written);
- its units (``drivers.cia402_units``: 0x608F/0x6091/0x6092/0x60A8/0x60A9, 0x6075/0x6076,
  else ``[axis.units]``);
- the mode: 0x6060 written (never read first: it may be write-only), then 0x6061 awaited
  for ``mode_timeout`` [s];
- the process data (``drivers.cia402_pdo``): ``pdo="remap"`` writes a mapping that fits the
  device (its PDOs, mappability, 64 bits) and falls back, with a warning, to
  ``pdo="device"`` when the device refuses; ``pdo="device"`` uses the mapping in force.
  Frames are decoded from the mapping in force (``drivers.cia402_process``).

No manufacturer object (0x2000-0x5FFF) is written, except the toolkit's own drive's command
latency 0x2001 on that drive (vendor 0xDB1, product 0x402). Every cycle ``supervise`` checks
the statusword and, where mapped, 0x6061: a drive that leaves OPERATION ENABLED or changes
mode stops the run, named.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import canopen

from drivers.base import AxisState, Feedback
from drivers.canopen_axis import CanopenAxis
from drivers.cia402_pdo import Key, Pdo, disable, numbers, plan_rpdo, plan_tpdos, read_mapping, variable
from drivers.cia402_pdo import write_mapping as write_pdo
from drivers.cia402_process import ProcessData
from drivers.cia402_units import DriveUnits, discover_units
from drivers.errors import (
    CommunicationError,
    CommunicationTimeout,
    ConfigError,
    DeviceFault,
    RigError,
    SafetyStop,
    SdoAbort,
)
from drivers.maps import CIA402_EDS, cia
from drivers.maps.cia import MODE_BITS, Controlword, Mode, PowerState
from drivers.maps.emcy import emcy_text

__all__ = ["Cia402Axis", "DriveUnits", "power_state"]

log = logging.getLogger(__name__)

#: the controlword that moves one step towards OPERATION ENABLED from each state
_TOWARDS_ENABLED = {
    PowerState.SWITCH_ON_DISABLED: Controlword.SHUTDOWN,
    PowerState.READY_TO_SWITCH_ON: Controlword.SWITCH_ON,
    PowerState.SWITCHED_ON: Controlword.ENABLE_OPERATION,
    PowerState.QUICK_STOP_ACTIVE: Controlword.DISABLE_VOLTAGE,
}
_AXIS_STATE = {
    PowerState.OPERATION_ENABLED: AxisState.ENABLED,
    PowerState.QUICK_STOP_ACTIVE: AxisState.STOPPING,
    PowerState.FAULT_REACTION_ACTIVE: AxisState.STOPPING,
    PowerState.FAULT: AxisState.FAULT,
}
_ENABLED_MASK, _ENABLED_BITS = PowerState.OPERATION_ENABLED.mask, PowerState.OPERATION_ENABLED.bits
TOOLKIT_DRIVE = (0xDB1, 0x402)  #: (vendor, product) of the toolkit's own emulated drive

SW: Key = (cia.STATUSWORD, 0)
CW: Key = (cia.CONTROLWORD, 0)
POSITION: Key = (cia.POSITION_ACTUAL, 0)
VELOCITY: Key = (cia.VELOCITY_ACTUAL, 0)
TORQUE: Key = (cia.TORQUE_ACTUAL, 0)
CURRENT: Key = (cia.CURRENT_ACTUAL, 0)
MODE_SHOWN: Key = (cia.MODES_DISPLAY, 0)
_DQ_RX = [(cia.DQ_VOLTAGE, 1), (cia.DQ_VOLTAGE, 2)]
_DQ_TX = [SW, (cia.FRAME_ANGLE, 0), (cia.FRAME_SPEED, 0), (cia.DQ_CURRENT, 1), (cia.DQ_CURRENT, 2)]


def interpolation_period(period: float) -> tuple[int, int]:
    """0x60C2: ``period`` [s] as (value 0-255, power of ten -128..63)."""
    for exponent in range(-6, 3):
        value = period / 10.0**exponent
        if value <= 255 and abs(value - round(value)) < 1e-6 * max(1.0, value):
            return round(value), exponent
    raise ConfigError(f"SYNC period {period!r} s cannot be written to 0x60C2 (value x 10^n, value <= 255)")


def power_state(statusword: int) -> PowerState:
    """The state a statusword reports; DeviceFault-free: an undecodable word is NOT READY."""
    return cia.decode_statusword(statusword) or PowerState.NOT_READY_TO_SWITCH_ON


class Cia402Axis(CanopenAxis):
    """A CiA 402 drive at ``node_id`` in ``mode`` (``drivers.base.AXIS_MODES``); SI in and out.

    ``units``: factors the device may lack (``counts_per_rev``, ``position_unit``,
    ``velocity_unit``, ``rated_torque`` [N m], ``rated_current`` [A]). ``sync_rpdo``: the RPDO
    acts at the next SYNC (one period of delay), else on receipt (``latency`` [s] later on the
    toolkit's own drive). ``pdo``: "remap" or "device" (see the module docstring).
    ``mode_timeout`` [s]: how long 0x6061 may take to follow 0x6060.
    """

    def __init__(
        self,
        name: str,
        network: canopen.Network,
        node_id: int,
        *,
        mode: str,
        eds: str = CIA402_EDS,
        units: Mapping[str, float] | None = None,
        sync_rpdo: bool = True,
        latency: float = 0.0,
        heartbeat_timeout: float = 0.0,
        pdo: str = "remap",
        mode_timeout: float = 1.0,
        sdo_timeout: float | None = None,
        sdo_retries: int | None = None,
        host: tuple[int, float] | None = None,
        abort_connection: int | None = None,
        period: float = 0.0,
        reset_fault: bool = False,
        emcy_texts: Mapping[int, str] | None = None,
    ) -> None:
        try:
            self.op_mode = cia.mode_code(mode)
        except ValueError as exc:
            raise ConfigError(f"axis {name!r}: {exc}") from None
        if pdo not in ("remap", "device"):
            raise ConfigError(f"axis {name!r}: pdo = {pdo!r}: remap or device")
        super().__init__(
            name,
            mode,
            network,
            node_id,
            eds=eds,
            heartbeat_timeout=heartbeat_timeout,
            sdo_timeout=sdo_timeout,
            sdo_retries=sdo_retries,
        )
        self.given_units = dict(units or {})
        self.sync_rpdo = sync_rpdo
        self.latency = latency
        self.pdo = pdo
        self.mode_timeout = mode_timeout
        self.host = host  #: (host node id, time [s]) the drive's heartbeat consumer watches
        self.abort_connection = abort_connection  #: 0x6007 (None: the drive's own)
        self.period = period  #: [s] the SYNC period (0x60C2, 0x1006), 0: not told
        self.reset_fault = reset_fault  #: a drive found in FAULT at enable is reset (else refused)
        self.emcy_texts = dict(emcy_texts or {})
        self._consumer_sub: int | None = None
        self.units = DriveUnits(math.nan, math.nan, math.nan, math.nan, {})
        self.measures = frozenset()
        self.identity: dict[str, int] = {}
        self.supported_modes: frozenset[int] | None = None
        self.data: ProcessData | None = None
        self._turns = 0
        self._angle: float | None = None
        self._enabled_stamp: float | None = None
        self._rest_stamp: float | None = None  #: the statusword TPDO's stamp at the last ``at_rest``
        #: called while waiting for the drive (set-up): lets time pass (a SYNC in lock-step)
        self.idle: Callable[[], None] = lambda: time.sleep(0.001)

    # --- set-up ----------------------------------------------------------------------------------
    def setup(self) -> None:
        """Identity, modes, units, PRE-OPERATIONAL, mode, process data, OPERATIONAL (still disabled)."""
        self.discover()
        self.nmt("PRE-OPERATIONAL")
        self.set_mode(self.op_mode)
        self.map_process_data()
        self.configure_supervision()
        self.nmt("OPERATIONAL")

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
            raise ConfigError(f"node {self.node_id} is not a CiA 402 drive (0x1000 = 0x{device_type:08X})")
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

    # --- process data ----------------------------------------------------------------------------
    def _wanted(self) -> tuple[list[Key], list[Key], list[Key]]:
        """(RPDO keys, TPDO keys needed, TPDO keys wanted if there is room)."""
        if self.op_mode == Mode.DQ_VOLTAGE:
            return list(_DQ_RX), list(_DQ_TX), []
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

    # --- state machine ---------------------------------------------------------------------------
    def read_power_state(self) -> PowerState:
        """The CiA 402 state, read by SDO."""
        return power_state(self.sdo_read(cia.STATUSWORD))

    def read_state(self) -> AxisState:
        return _AXIS_STATE.get(self.read_power_state(), AxisState.DISABLED)

    def _drive_to(self, target: PowerState, step: Callable[[PowerState], int | None], timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while True:
            state = self.read_power_state()
            if state is target:
                return
            if state is PowerState.FAULT and target is not PowerState.SWITCH_ON_DISABLED:
                raise DeviceFault(f"drive in FAULT while going to {target.value}", device=self.where)
            cw = step(state)
            if cw is not None:
                self.sdo_write(cia.CONTROLWORD, 0, int(cw))
            if time.monotonic() > deadline:
                raise CommunicationTimeout(
                    f"node {self.node_id}: still {state.value} after {timeout:g} s, wanted {target.value}"
                )

    def fault_text(self) -> str:
        """What the drive's 0x603F holds, in words (or that it has none)."""
        code = self._optional(cia.ERROR_CODE)
        if code is None:
            return "no 0x603F"
        return f"0x603F = 0x{int(code):04X}, {emcy_text(int(code), self.emcy_texts)}"

    def enable(self, *, timeout: float = 1.0) -> None:
        """Shutdown, switch on, enable operation (transitions 2, 3, 4), within ``timeout`` [s]; a
        drive in FAULT is reset first with ``reset_fault``, else refused, saying what 0x603F holds."""
        if self.read_power_state() is PowerState.FAULT:
            what = self.fault_text()
            if not self.reset_fault:
                raise DeviceFault(
                    f"the drive is in FAULT ({what}); set reset_fault = true on the axis "
                    "(or rig run --reset-fault) to reset it",
                    device=self.where,
                )
            log.warning("%s: the drive was in FAULT (%s): resetting it", self.where, what)
            self.fault_reset(timeout=timeout)
        self.clear_fault()
        if self.host is not None and self._consumer_sub is None and self.data is not None:
            if cia.CONSUMER_HEARTBEAT in self.node.object_dictionary:
                self._consumer_sub = self._watch_host(*self.host)
        self._drive_to(PowerState.OPERATION_ENABLED, _TOWARDS_ENABLED.get, timeout)
        slot = self.data.slot_of(SW) if self.data else None
        self._enabled_stamp = slot.timestamp if slot else None

    def fault_reset(self, *, timeout: float = 1.0) -> None:
        """Rising edge of controlword bit 7 (transition 15)."""
        if self.read_power_state() is not PowerState.FAULT:
            return
        self.sdo_write(cia.CONTROLWORD, 0, int(Controlword.DISABLE_VOLTAGE))
        self._drive_to(
            PowerState.SWITCH_ON_DISABLED,
            lambda s: Controlword.FAULT_RESET if s is PowerState.FAULT else None,
            timeout,
        )

    def quick_stop(self) -> None:
        """Quick stop command (transition 11), by SDO so it acts now."""
        self.sdo_write(cia.CONTROLWORD, 0, int(Controlword.QUICK_STOP))

    def at_rest(self, fb: Feedback) -> bool:
        """After a quick stop: the statusword shows the ramp ended (SWITCH ON DISABLED, FAULT), or
        QUICK STOP ACTIVE with the motor at rest (0x605A options 5-8). The statusword of the last
        TPDO, or read by SDO when no new TPDO came since the last call (TPDOs may have stopped)."""
        data = self.data
        slot = data.slot_of(SW) if data is not None else None
        if slot is not None and slot.timestamp is not None and slot.timestamp != self._rest_stamp:
            self._rest_stamp = slot.timestamp
            word = data.value(SW)  # type: ignore[union-attr]
        else:
            word = self.sdo_read(cia.STATUSWORD)
        state = power_state(word)
        if state in (PowerState.SWITCH_ON_DISABLED, PowerState.FAULT, PowerState.NOT_READY_TO_SWITCH_ON):
            return True
        return state is PowerState.QUICK_STOP_ACTIVE and abs(fb.velocity) < self.REST_SPEED

    def disable(self) -> None:
        """Disable voltage (transitions 7, 9, 10, 12), then stop watching the host's heartbeat."""
        self.sdo_write(cia.CONTROLWORD, 0, int(Controlword.DISABLE_VOLTAGE))
        self._unwatch_host()

    # --- the cycle -------------------------------------------------------------------------------
    def feedback(self) -> Feedback:
        """The last TPDOs in SI (the frame angle unwrapped in mode -2)."""
        data, u = self.data, self.units
        assert data is not None
        if self.op_mode == Mode.DQ_VOLTAGE:
            return self._dq_feedback(data)
        stamp = self._motion.timestamp if self._motion is not None else time.monotonic()
        return Feedback(
            data.value(POSITION) / u.position,
            data.value(VELOCITY) / u.velocity,
            data.value(TORQUE) / 1000.0 * u.rated_torque if "torque" in self.measures else math.nan,
            data.value(CURRENT) / 1000.0 * u.rated_current if "current" in self.measures else math.nan,
            stamp,
        )

    def _dq_feedback(self, data: ProcessData) -> Feedback:
        i_dq = complex(data.value((cia.DQ_CURRENT, 1)), data.value((cia.DQ_CURRENT, 2))) / 1000.0
        angle = data.value((cia.FRAME_ANGLE, 0)) * 1e-6
        if self._angle is not None:  # unwrap: a position like any other
            self._turns += round((self._angle - angle) / (2.0 * math.pi))
        self._angle = angle
        slot = data.slot_of((cia.DQ_CURRENT, 1))
        stamp = slot.timestamp if slot else None
        speed = data.value((cia.FRAME_SPEED, 0)) * 1e-3
        return Feedback(angle + 2.0 * math.pi * self._turns, speed, math.nan, abs(i_dq), stamp, i_dq)

    def supervise(self, now: float) -> None:
        """EMCY, NMT and heartbeat (``CanopenAxis``), the statusword and, where mapped, 0x6061."""
        super().supervise(now)
        data = self.data
        assert data is not None
        slot = data.slot_of(SW)
        if slot is None or slot.timestamp is None or slot.timestamp == self._enabled_stamp:
            return
        word = data.value(SW)
        if word & _ENABLED_MASK != _ENABLED_BITS:
            raise SafetyStop(
                f"node {self.node_id}: the drive left OPERATION ENABLED: {power_state(word).value}"
            )
        if data.mapped(MODE_SHOWN):
            shown = data.value(MODE_SHOWN)
            if shown != self.op_mode:
                raise SafetyStop(f"node {self.node_id}: the drive changed its mode to {shown} (0x6061)")

    def command(self, value: float | complex) -> None:
        """Send the SI command of the mode in the RPDO (applied per its transmission type)."""
        data = self.data
        assert data is not None and data.rpdo is not None
        if self.op_mode == Mode.DQ_VOLTAGE:
            u = complex(value)
            frame = data.frame({_DQ_RX[0]: round(u.real * 1000.0), _DQ_RX[1]: round(u.imag * 1000.0)})
        else:
            target = cia.TARGET_OF_MODE[self.op_mode]
            raw = self.units.command_raw(self.op_mode, float(value))  # type: ignore[arg-type]
            frame = data.frame({CW: int(Controlword.ENABLE_OPERATION), target: raw})
        try:
            self.network.send_message(data.rpdo.cob_id, frame)
        except RigError:
            raise
        except Exception as exc:  # python-can errors, a closed socket
            raise CommunicationError(f"node {self.node_id}: {data.rpdo.name} not sent: {exc}") from exc
