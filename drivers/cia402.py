"""Host-side CiA 402 drive driver over canopen.

It builds on canopen's ``RemoteNode`` (SDO client, PDO maps, NMT, EMCY
consumer), not on ``BaseNode402``. BaseNode402's fault reset always waits
about 400 ms (canopen #261), it asserts on the NMT state (#309), and a
controlword mapped in a synchronous RPDO is only buffered until that RPDO is
transmitted, which BaseNode402 does not do unless the RPDO runs periodically.
The driver here writes the controlword by SDO during state changes, which is
deterministic in lock-step and in real time, and leaves the RPDOs to the host
loop, which transmits them once per cycle.

Units: the device's units are converted in one place (``DriveUnits``) from
the factors the device itself reports: 0x608F (increments per revolution),
0x6076 (rated torque, mN m), 0x6075 (rated current, mA); voltages in mV.
"""

from __future__ import annotations

import logging
import math
import struct
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import canopen
from canopen.emcy import EmcyError
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from drivers.errors import CommunicationError, CommunicationTimeout, ConfigError, DeviceFault, SdoAbort
from drivers.maps import CIA402_EDS
from drivers.maps.od import load_od

__all__ = ["MODES", "STATES", "Cia402Drive", "DriveUnits", "decode_state"]

log = logging.getLogger(__name__)

#: CiA 402 modes of operation (0x6060) by name; negative ones are this toolkit's manufacturer modes.
MODES = {"pv": 3, "csp": 8, "csv": 9, "cst": 10, "voltage": -1, "dq-voltage": -2}
#: statusword (mask, value) per state, CiA 402.
STATES = {
    "NOT READY TO SWITCH ON": (0x4F, 0x00),
    "SWITCH ON DISABLED": (0x4F, 0x40),
    "READY TO SWITCH ON": (0x6F, 0x21),
    "SWITCHED ON": (0x6F, 0x23),
    "OPERATION ENABLED": (0x6F, 0x27),
    "QUICK STOP ACTIVE": (0x6F, 0x07),
    "FAULT REACTION ACTIVE": (0x4F, 0x0F),
    "FAULT": (0x4F, 0x08),
}
#: the controlword that moves one step towards OPERATION ENABLED from each state.
_TOWARDS_ENABLED = {
    "SWITCH ON DISABLED": 0x06,
    "READY TO SWITCH ON": 0x07,
    "SWITCHED ON": 0x0F,
    "QUICK STOP ACTIVE": 0x00,
}


def decode_state(statusword: int) -> str:
    """The CiA 402 state a statusword reports."""
    for name, (mask, value) in STATES.items():
        if statusword & mask == value:
            return name
    return f"UNKNOWN (0x{statusword:04X})"


@dataclass(frozen=True)
class DriveUnits:
    """Device unit <-> SI factors, read from the drive."""

    counts_per_rad: float
    rated_torque: float  #: [N m]
    rated_current: float  #: [A]

    def command_raw(self, mode: int, value: float) -> int:
        """SI command of ``mode`` -> the raw target value."""
        if mode == MODES["voltage"]:
            return round(value * 1000.0)  # V -> mV
        if mode == MODES["cst"]:
            return round(value / self.rated_torque * 1000.0)  # N m -> per mille
        if mode in (MODES["csv"], MODES["pv"]):
            return round(value * self.counts_per_rad)  # rad/s -> inc/s
        if mode == MODES["csp"]:
            return round(value * self.counts_per_rad)  # rad -> inc
        raise ConfigError(f"mode {mode} has no scalar command")


_STATUSWORD = struct.Struct("<H")

#: target object per mode
_TARGET = {-1: (0x2100, 0), 3: (0x60FF, 0), 8: (0x607A, 0), 9: (0x60FF, 0), 10: (0x6071, 0)}


class Cia402Drive:
    """A CiA 402 drive on ``network`` at ``node_id``; SI in and out."""

    def __init__(
        self, network: canopen.Network, node_id: int, *, eds: str = CIA402_EDS, sdo_timeout: float = 0.3
    ):
        self.node_id = node_id
        self.node: Any = canopen.RemoteNode(node_id, load_od(eds, node_id))
        self.node.sdo.RESPONSE_TIMEOUT = sdo_timeout
        self.node.sdo.MAX_RETRIES = 1
        network.add_node(self.node)
        self.emcy_log: list[str] = []
        self.fault: DeviceFault | None = None
        self.node.emcy.add_callback(self._on_emcy)
        self.units: DriveUnits | None = None
        self.mode = 0

    # --- SDO with the toolkit's errors ---------------------------------------
    def _entry(self, index: int, subindex: int) -> Any:
        obj = self.node.sdo[index]
        return obj[subindex] if subindex or not hasattr(obj, "raw") else obj

    def _translate(self, exc: Exception, what: str, index: int, subindex: int) -> Exception:
        if isinstance(exc, SdoAbortedError):
            return SdoAbort(what, code=exc.code, node_id=self.node_id, index=index, subindex=subindex)
        return CommunicationTimeout(
            f"node {self.node_id}: no SDO answer ({what}, 0x{index:04X}:{subindex:02X})"
        )

    def sdo_read(self, index: int, subindex: int = 0) -> Any:
        """Read an object by SDO (bytes if the EDS lacks it); raises SdoAbort or CommunicationTimeout."""
        try:
            if index not in self.node.object_dictionary:
                return self.node.sdo.upload(index, subindex)
            return self._entry(index, subindex).raw
        except (SdoAbortedError, SdoCommunicationError) as exc:
            raise self._translate(exc, "SDO upload", index, subindex) from exc

    def sdo_write(self, index: int, subindex: int, value: Any) -> None:
        """Write an object by SDO; SdoAbort or CommunicationTimeout on failure."""
        try:
            self._entry(index, subindex).raw = value
        except (SdoAbortedError, SdoCommunicationError) as exc:
            raise self._translate(exc, f"SDO download of {value!r}", index, subindex) from exc

    # --- setup ---------------------------------------------------------------
    def connect(self) -> DriveUnits:
        """Check the device type and read the unit factors."""
        device_type = self.sdo_read(0x1000)
        if device_type & 0xFFFF != 402:
            raise ConfigError(f"node {self.node_id} is not a CiA 402 drive (0x1000 = 0x{device_type:08X})")
        increments, revolutions = self.sdo_read(0x608F, 1), self.sdo_read(0x608F, 2)
        self.units = DriveUnits(
            increments / (revolutions * 2.0 * math.pi),
            self.sdo_read(0x6076) / 1000.0,
            self.sdo_read(0x6075) / 1000.0,
        )
        return self.units

    def _map_pdos(
        self,
        rpdo: list[tuple[int, int]],
        tpdos: dict[int, list[tuple[int, int]]],
        sync_rpdo: bool,
        latency_s: float,
    ) -> None:
        """RPDO1 = ``rpdo`` (synchronous, or applied ``latency_s`` after receipt), the other RPDOs off;
        TPDO n = ``tpdos[n]`` on every SYNC; written to the drive through SDO."""
        self.node.rpdo.read()
        self.node.tpdo.read()
        for n in (1, 2, 3, 4):
            rp = self.node.rpdo[n]
            rp.clear()
            for index, sub in rpdo if n == 1 else ():
                rp.add_variable(index, sub)
            rp.trans_type = 1 if sync_rpdo else 255
            rp.enabled = n == 1
        for n, entries in tpdos.items():
            tp = self.node.tpdo[n]
            tp.clear()
            for index, sub in entries:
                tp.add_variable(index, sub)
            tp.trans_type = 1
            tp.enabled = True
        try:
            self.node.rpdo.save()
            self.node.tpdo.save()
        except SdoAbortedError as exc:
            raise SdoAbort(
                "PDO mapping refused", code=exc.code, node_id=self.node_id, index=0x1600, subindex=0
            ) from exc
        self.sdo_write(0x2001, 0, 0 if sync_rpdo else round(latency_s * 1e6))
        self._rpdo = self.node.rpdo[1]

    def configure_pdos(self, *, sync_rpdo: bool = True, latency_s: float = 0.0) -> None:
        """Map the process data the host loop uses: RPDO1 controlword + target of the mode,
        TPDO2 position + velocity and TPDO3 statusword + torque + current, every SYNC."""
        if self.mode not in _TARGET:
            raise ConfigError(f"node {self.node_id}: set a mode with a scalar target before mapping PDOs")
        self._map_pdos(
            [(0x6040, 0), _TARGET[self.mode]],
            {2: [(0x6064, 0), (0x606C, 0)], 3: [(0x6041, 0), (0x6077, 0), (0x6078, 0)]},
            sync_rpdo,
            latency_s,
        )
        # the process data are packed and unpacked with struct, in the layout mapped above:
        # canopen's Variable.raw decodes and logs on every access, too slow for the cycle
        target_bits = len(self._rpdo[1].od)
        self._rpdo_format = struct.Struct("<Hi" if target_bits == 32 else "<Hh")
        self._tpdo2, self._tpdo3 = self.node.tpdo[2], self.node.tpdo[3]
        self._tpdo2_format, self._tpdo3_format = struct.Struct("<ii"), struct.Struct("<Hhh")

    def set_mode(self, mode: str | int) -> None:
        """Write 0x6060 and check 0x6061."""
        code = MODES.get(mode, mode) if isinstance(mode, str) else mode
        if not isinstance(code, int):
            raise ConfigError(f"unknown mode {mode!r}; known: {', '.join(MODES)}")
        self.sdo_write(0x6060, 0, code)
        shown = self.sdo_read(0x6061)
        if shown != code:
            raise DeviceFault(f"mode {code} requested, 0x6061 shows {shown}", device=f"node {self.node_id}")
        self.mode = code

    def configure_dq_pdos(self, *, sync_rpdo: bool = True, latency_s: float = 0.0) -> None:
        """Process data of mode -2 (dq voltage): RPDO1 u_d, u_q [mV] (0x2200); TPDO4 i_d, i_q [mA]
        (0x2210), TPDO2 frame angle [urad] and speed [mrad/s] (0x2220, 0x2221), TPDO3 statusword."""
        self._map_pdos(
            [(0x2200, 1), (0x2200, 2)],
            {2: [(0x2220, 0), (0x2221, 0)], 3: [(0x6041, 0)], 4: [(0x2210, 1), (0x2210, 2)]},
            sync_rpdo,
            latency_s,
        )
        self._dq = struct.Struct("<ii")
        self._tpdo2, self._tpdo3, self._tpdo4 = self.node.tpdo[2], self.node.tpdo[3], self.node.tpdo[4]

    def dq_feedback(self) -> tuple[complex, float, float, int]:
        """(i_dq [A], frame angle [rad], frame speed [rad/s], statusword) from the last TPDOs."""
        i_d, i_q = self._unpack(self._tpdo4, self._dq)
        angle, speed = self._unpack(self._tpdo2, self._dq)
        (statusword,) = self._unpack(self._tpdo3, _STATUSWORD)
        return complex(i_d, i_q) / 1000.0, angle * 1e-6, speed * 1e-3, statusword

    def dq_command(self, u: complex) -> None:
        """Send the dq voltage reference u [V] in RPDO1."""
        self._rpdo.data = self._dq.pack(round(u.real * 1000.0), round(u.imag * 1000.0))
        self._rpdo.transmit()

    # --- state machine ---------------------------------------------------------
    @property
    def state(self) -> str:
        return decode_state(self.sdo_read(0x6041))

    def _drive_to(
        self, target: str, step: Callable[[str], int | None], timeout: float, poll: Callable[[], None] | None
    ) -> None:
        deadline = time.monotonic() + timeout
        while True:
            state = self.state
            if state == target:
                return
            if state == "FAULT" and target != "SWITCH ON DISABLED":
                raise DeviceFault(f"drive in FAULT while going to {target}", device=f"node {self.node_id}")
            cw = step(state)
            if cw is not None:
                self.sdo_write(0x6040, 0, cw)
            if poll is not None:
                poll()
            if time.monotonic() > deadline:
                raise CommunicationTimeout(
                    f"node {self.node_id}: still {state} after {timeout:g} s, wanted {target}"
                )

    def enable(self, *, timeout: float = 1.0, poll: Callable[[], None] | None = None) -> None:
        """Shutdown, switch on, enable operation (transitions 2, 3, 4), within ``timeout`` [s]."""
        self.fault = None
        self._drive_to("OPERATION ENABLED", _TOWARDS_ENABLED.get, timeout, poll)

    def fault_reset(self, *, timeout: float = 1.0, poll: Callable[[], None] | None = None) -> None:
        """Rising edge of controlword bit 7 (transition 15)."""
        if self.state != "FAULT":
            return
        self.sdo_write(0x6040, 0, 0x00)
        self._drive_to("SWITCH ON DISABLED", lambda s: 0x80 if s == "FAULT" else None, timeout, poll)

    def quick_stop(self) -> None:
        """Quick stop command (transition 11), by SDO so it acts now."""
        self.sdo_write(0x6040, 0, 0x02)

    def disable(self) -> None:
        """Disable voltage (transitions 7, 9, 10, 12)."""
        self.sdo_write(0x6040, 0, 0x00)

    # --- process data ------------------------------------------------------------
    def feedback(self) -> tuple[float, float, float, float, int]:
        """(position [rad], velocity [rad/s], torque [N m], current [A], statusword) from the last TPDOs."""
        u = self.units
        assert u is not None, "connect() first"
        position, velocity = self._unpack(self._tpdo2, self._tpdo2_format)
        statusword, torque, current = self._unpack(self._tpdo3, self._tpdo3_format)
        return (
            position / u.counts_per_rad,
            velocity / u.counts_per_rad,
            torque / 1000.0 * u.rated_torque,
            current / 1000.0 * u.rated_current,
            statusword,
        )

    def _unpack(self, pdo: Any, layout: struct.Struct) -> tuple[Any, ...]:
        """The values of a received TPDO; CommunicationError naming it when its length is wrong."""
        data = pdo.data
        if len(data) < layout.size:
            raise CommunicationError(
                f"node {self.node_id}: TPDO 0x{pdo.cob_id:03X} has {len(data)} bytes, "
                f"its mapping {layout.size}"
            )
        return layout.unpack_from(data)

    def command(self, value: float, controlword: int = 0x0F) -> None:
        """Send the SI command of the active mode in RPDO1 (applied per its transmission type)."""
        assert self.units is not None, "connect() first"
        rpdo = self._rpdo
        rpdo.data = self._rpdo_format.pack(controlword, self.units.command_raw(self.mode, value))
        rpdo.transmit()

    def _on_emcy(self, err: EmcyError) -> None:
        text = f"EMCY 0x{err.code:04X} ({err.get_desc() or 'unknown'}), error register 0x{err.register:02X}"
        self.emcy_log.append(text)
        if err.code:
            log.warning("node %d: %s", self.node_id, text)
            self.fault = DeviceFault(text, device=f"node {self.node_id}", code=err.code)

    @property
    def last_heartbeat(self) -> float | None:
        """Timestamp [s] of the last heartbeat received, or None."""
        ts = self.node.nmt.timestamp
        return float(ts) if ts is not None else None

    @property
    def nmt_state(self) -> str:
        """The node's NMT state as last commanded or reported (heartbeat, boot-up)."""
        return str(self.node.nmt.state)

    def nmt(self, state: str) -> None:
        self.node.nmt.state = state

    def emcy_texts(self) -> Sequence[str]:
        return tuple(self.emcy_log)
