"""Host-side CiA 402 drive: an ``AxisDriver`` on canopen's ``RemoteNode``.

It builds on ``RemoteNode`` (SDO client, PDO maps, NMT, EMCY consumer), not on
``BaseNode402``. BaseNode402's fault reset always waits about 400 ms (canopen
#261), it asserts on the NMT state (#309), and a controlword mapped in a
synchronous RPDO is only buffered until that RPDO is transmitted, which
BaseNode402 does not do unless the RPDO runs periodically. Here the
controlword goes by SDO during state changes, which is deterministic in
lock-step and in real time, and the host loop transmits RPDO1 once per cycle.

Units are converted in one place (``DriveUnits``) from the factors the device
reports: 0x608F (increments per revolution), 0x6076 (rated torque, mN m),
0x6075 (rated current, mA); where the device lacks one, from the axis
configuration. Voltages in mV; dq currents in mA, frame angle in urad.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import canopen

from drivers.base import AxisState, Feedback
from drivers.canopen_axis import CanopenAxis, TpdoSlot, pdo_codec
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
from drivers.maps.cia import Controlword, Mode, PowerState

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


def power_state(statusword: int) -> PowerState:
    """The state a statusword reports; DeviceFault-free: an undecodable word is NOT READY."""
    return cia.decode_statusword(statusword) or PowerState.NOT_READY_TO_SWITCH_ON


@dataclass(frozen=True)
class DriveUnits:
    """Device unit <-> SI factors (from the drive, else from the configuration; NaN: unknown)."""

    counts_per_rad: float
    rated_torque: float  #: [N m]
    rated_current: float  #: [A]

    def command_raw(self, mode: Mode, value: float) -> int:
        """SI command of ``mode`` -> the raw target value."""
        if mode == Mode.VOLTAGE:
            return round(value * 1000.0)  # V -> mV
        if mode == Mode.CST:
            return round(value / self.rated_torque * 1000.0)  # N m -> per mille
        return round(value * self.counts_per_rad)  # rad/s -> inc/s, rad -> inc


#: the units each mode's command needs: (DriveUnits field, object, [axis.units] key)
_NEEDS = {
    Mode.CST: ("rated_torque", cia.RATED_TORQUE, "rated_torque"),
    Mode.CSV: ("counts_per_rad", cia.POSITION_ENCODER_RESOLUTION, "counts_per_rev"),
    Mode.PROFILE_VELOCITY: ("counts_per_rad", cia.POSITION_ENCODER_RESOLUTION, "counts_per_rev"),
    Mode.CSP: ("counts_per_rad", cia.POSITION_ENCODER_RESOLUTION, "counts_per_rev"),
}


class Cia402Axis(CanopenAxis):
    """A CiA 402 drive at ``node_id`` in ``mode`` (``drivers.base.AXIS_MODES``); SI in and out.

    ``units`` gives factors the device may lack: ``counts_per_rev``, ``rated_torque`` [N m],
    ``rated_current`` [A] (0: not given). ``sync_rpdo``: RPDO1 applies at the next SYNC
    (one period of delay); otherwise on receipt, ``latency`` [s] later (0x2001 of the
    toolkit's drive).
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
    ) -> None:
        try:
            self.op_mode = cia.mode_code(mode)
        except ValueError as exc:
            raise ConfigError(f"axis {name!r}: {exc}") from None
        super().__init__(name, mode, network, node_id, eds=eds, heartbeat_timeout=heartbeat_timeout)
        self.given_units = dict(units or {})
        self.sync_rpdo = sync_rpdo
        self.latency = latency
        self.units = DriveUnits(math.nan, math.nan, math.nan)
        self.measures = frozenset()
        self._turns = 0
        self._angle: float | None = None

    # --- setup ---------------------------------------------------------------------------------
    def setup(self) -> None:
        """Device type, units, PRE-OPERATIONAL, mode, process data, OPERATIONAL (still disabled)."""
        self.read_units()
        self.nmt("PRE-OPERATIONAL")
        self.set_mode(self.op_mode)
        self.map_process_data()
        self.nmt("OPERATIONAL")

    def _optional(self, index: int, subindex: int = 0) -> Any:
        """An object the device may lack: its value, or None (any SDO abort)."""
        if index not in self.node.object_dictionary:
            return None
        try:
            return self.sdo_read(index, subindex)
        except SdoAbort:
            return None

    def read_units(self) -> DriveUnits:
        """Check 0x1000 and take the unit factors from the device or the configuration."""
        device_type = self.sdo_read(cia.DEVICE_TYPE)
        if device_type & 0xFFFF != cia.PROFILE_DRIVE:
            raise ConfigError(f"node {self.node_id} is not a CiA 402 drive (0x1000 = 0x{device_type:08X})")
        given = self.given_units
        increments = self._optional(cia.POSITION_ENCODER_RESOLUTION, 1)
        revolutions = self._optional(cia.POSITION_ENCODER_RESOLUTION, 2) or 1
        per_rev = increments / revolutions if increments else given.get("counts_per_rev", 0.0)
        torque = self._optional(cia.RATED_TORQUE)
        current = self._optional(cia.RATED_CURRENT)
        self.units = DriveUnits(
            per_rev / (2.0 * math.pi) if per_rev else math.nan,
            torque / 1000.0 if torque else given.get("rated_torque", 0.0) or math.nan,
            current / 1000.0 if current else given.get("rated_current", 0.0) or math.nan,
        )
        need = _NEEDS.get(self.op_mode)
        if need is not None and not math.isfinite(getattr(self.units, need[0])):
            raise ConfigError(
                f"axis {self.name!r} (node {self.node_id}): mode {self.mode} needs 0x{need[1]:04X}, which "
                f"the drive does not give; set [axis.units] {need[2]}"
            )
        return self.units

    def set_mode(self, mode: Mode) -> None:
        """Write 0x6060 and check 0x6061."""
        self.sdo_write(cia.MODES_OF_OPERATION, 0, int(mode))
        shown = self.sdo_read(cia.MODES_DISPLAY)
        if shown != mode:
            raise DeviceFault(f"mode {int(mode)} requested, 0x6061 shows {shown}", device=self.where)

    def _map(self, rpdo: list[tuple[int, int]], tpdos: dict[int, list[tuple[int, int]]]) -> None:
        """RPDO1 = ``rpdo``, the other RPDOs off; TPDO n = ``tpdos[n]`` on every SYNC (by SDO)."""
        node = self.node
        node.rpdo.read()
        node.tpdo.read()
        for n in (1, 2, 3, 4):
            rp = node.rpdo[n]
            rp.clear()
            for index, sub in rpdo if n == 1 else ():
                rp.add_variable(index, sub)
            rp.trans_type = 1 if self.sync_rpdo else cia.PDO_EVENT_TYPES[-1]
            rp.enabled = n == 1
        for n, entries in tpdos.items():
            tp = node.tpdo[n]
            tp.clear()
            for index, sub in entries:
                tp.add_variable(index, sub)
            tp.trans_type = 1
            tp.enabled = True
        self.save_pdos(node.rpdo, cia.RPDO_MAP)
        self.save_pdos(node.tpdo, cia.TPDO_MAP)
        if cia.COMMAND_LATENCY in node.object_dictionary:
            self.sdo_write(cia.COMMAND_LATENCY, 0, 0 if self.sync_rpdo else round(self.latency * 1e6))
        self._rpdo_cob = node.rpdo[1].cob_id
        self._rpdo_codec = pdo_codec(node.rpdo[1])

    def map_process_data(self) -> None:
        """RPDO1 controlword + target (or u_dq in mode -2); TPDO2 position + velocity (frame angle +
        speed), TPDO3 statusword + torque + current (statusword), TPDO4 i_dq in mode -2."""
        if self.op_mode == Mode.DQ_VOLTAGE:
            self._map(
                [(cia.DQ_VOLTAGE, 1), (cia.DQ_VOLTAGE, 2)],
                {
                    2: [(cia.FRAME_ANGLE, 0), (cia.FRAME_SPEED, 0)],
                    3: [(cia.STATUSWORD, 0)],
                    4: [(cia.DQ_CURRENT, 1), (cia.DQ_CURRENT, 2)],
                },
            )
            self.measures = frozenset({"position", "velocity", "current"})
        else:
            if self.op_mode not in cia.TARGET_OF_MODE:
                raise ConfigError(f"axis {self.name!r}: mode {self.mode} has no cyclic target")
            self._map(
                [(cia.CONTROLWORD, 0), cia.TARGET_OF_MODE[self.op_mode]],
                {
                    2: [(cia.POSITION_ACTUAL, 0), (cia.VELOCITY_ACTUAL, 0)],
                    3: [(cia.STATUSWORD, 0), (cia.TORQUE_ACTUAL, 0), (cia.CURRENT_ACTUAL, 0)],
                },
            )
            u = self.units
            self.measures = frozenset(
                {"position", "velocity"}
                | ({"torque"} if math.isfinite(u.rated_torque) else set())
                | ({"current"} if math.isfinite(u.rated_current) else set())
            )
        tpdo = self.node.tpdo
        self._motion: TpdoSlot = self.receive(tpdo[2])
        self._status: TpdoSlot = self.receive(tpdo[3])
        self._dq: TpdoSlot | None = self.receive(tpdo[4]) if self.op_mode == Mode.DQ_VOLTAGE else None
        self._enabled_stamp: float | None = None

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

    def enable(self, *, timeout: float = 1.0) -> None:
        """Shutdown, switch on, enable operation (transitions 2, 3, 4), within ``timeout`` [s]."""
        self.clear_fault()
        self._drive_to(PowerState.OPERATION_ENABLED, _TOWARDS_ENABLED.get, timeout)
        self._enabled_stamp = self._status.timestamp

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

    def disable(self) -> None:
        """Disable voltage (transitions 7, 9, 10, 12)."""
        self.sdo_write(cia.CONTROLWORD, 0, int(Controlword.DISABLE_VOLTAGE))

    # --- process data ---------------------------------------------------------------------------
    def feedback(self) -> Feedback:
        """The last TPDOs in SI (the frame angle unwrapped in mode -2)."""
        if self._dq is not None:
            return self._dq_feedback(self._dq)
        u = self.units
        position, velocity = self._motion.values()
        _, torque, current = self._status.values()
        return Feedback(
            position / u.counts_per_rad,
            velocity / u.counts_per_rad,
            torque / 1000.0 * u.rated_torque,
            current / 1000.0 * u.rated_current,
            self._motion.timestamp,
        )

    def _dq_feedback(self, dq: TpdoSlot) -> Feedback:
        i_d, i_q = dq.values()
        angle, speed = self._motion.values()
        angle *= 1e-6
        if self._angle is not None:  # unwrap: a position like any other
            self._turns += round((self._angle - angle) / (2.0 * math.pi))
        self._angle = angle
        i_dq = complex(i_d, i_q) / 1000.0
        return Feedback(
            angle + 2.0 * math.pi * self._turns, speed * 1e-3, math.nan, abs(i_dq), dq.timestamp, i_dq
        )

    def supervise(self, now: float) -> None:
        """EMCY, NMT and heartbeat (``CanopenAxis``), and the statusword of the last TPDO3."""
        super().supervise(now)
        status = self._status
        if status.timestamp is not None and status.timestamp != self._enabled_stamp:
            word = status.values()[0]
            if word & _ENABLED_MASK != _ENABLED_BITS:
                raise SafetyStop(
                    f"node {self.node_id}: the drive left OPERATION ENABLED: {power_state(word).value}"
                )

    def command(self, value: float | complex) -> None:
        """Send the SI command of the mode in RPDO1 (applied per its transmission type)."""
        if self._dq is not None:
            u = complex(value)
            data = self._rpdo_codec.pack(round(u.real * 1000.0), round(u.imag * 1000.0))
        else:
            raw = self.units.command_raw(self.op_mode, float(value))  # type: ignore[arg-type]
            data = self._rpdo_codec.pack(int(Controlword.ENABLE_OPERATION), raw)
        try:
            self.network.send_message(self._rpdo_cob, data)
        except RigError:
            raise
        except Exception as exc:  # python-can errors, a closed socket
            raise CommunicationError(f"node {self.node_id}: RPDO1 not sent: {exc}") from exc
