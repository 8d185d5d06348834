"""An emulated CiA 402 drive on the bus: any EDS plus a device profile, with an ``Axis`` behind it.

The drive is built from a device profile (``plant_emulator.device_profile``):
its EDS gives the objects, the profile what the EDS cannot (modes where 0x6502
is absent, units, fixed or remappable PDOs, timings, the stop reactions). The
toolkit's own drive is the profile ``drive-rig`` (voltage mode -1 and dq voltage
mode -2 beside CST, CSV, PV and CSP).

Per SYNC (period ``period`` [s]): the physics advances one period with the
commands in force (the drive's ``Shaft``, once for all the nodes on it), the
drive runs its own cycle (a pending mode switch, its limits, the stop ramps)
and latches the feedback into the objects it has (``ProcessImage``, in its own
units) before its synchronous TPDOs go out (``plant_emulator.drive_cycle``). A drive whose power stage is off
gives no commands and lets its axis coast; an NMT reset lets go of the axis
(the shaft keeps its motion). Command timing is the two delay cases of the
dq-current paper: a synchronous RPDO (type 0-240) is applied at the next SYNC
(one period of delay: s-PWM-start); an event RPDO (type 254/255) is applied a
latency after receipt (the profile's ``pdo_latency``, or the toolkit's 0x2001
[us]: s-PWM-middle with T_s/2). SDO writes of a target act at the next SYNC.
A write of 0x6060 shows in 0x6061 after the profile's ``mode_switch`` time.

How the drive protects and stops itself (limits, faults, the quick-stop and fault
reaction ramps, the reaction to a lost host: 0x6007) is ``plant_emulator.drive_safety``;
its profile modes (profile position and velocity, homing, halt) are
``plant_emulator.profile_modes``; its units and process data ``plant_emulator.process_image``.

Writes to the profile's harmful manufacturer objects (e.g. a CAN bit rate at
0x2001) are logged and kept in ``harmful_writes``, so a test can tell that a
host wrote where it must not.
"""

from __future__ import annotations

import functools
import logging
from typing import Any

import canopen
from canopen.sdo.exceptions import SdoAbortedError

from drivers.maps import cia
from drivers.maps.cia import (
    MODE_BITS,
    TARGET_OF_MODE,
    EmcyCode,
    Mode,
    PowerState,
    QuickStopOption,
    SdoAbortCode,
)
from plant_emulator.axes import Axis
from plant_emulator.braking import Braking
from plant_emulator.canopen_node import OPERATIONAL, EmulatedNode
from plant_emulator.cia402_state import PowerStateMachine
from plant_emulator.device_profile import DEVICES_DIR, DeviceProfile, load_profile
from plant_emulator.drive_cycle import DriveCycle
from plant_emulator.drive_safety import FAULT_CODES, DriveSafety
from plant_emulator.interpolation import IP_OBJECTS
from plant_emulator.process_image import UNIT_OBJECTS, ProcessImage, Ratings
from plant_emulator.profile_modes import PROFILE_MODES, ProfileModes
from plant_emulator.shaft import Shaft, Timed

__all__ = ["FAULT_CODES", "EmulatedDrive", "Ratings", "toolkit_profile"]

log = logging.getLogger(__name__)

#: objects holding a command: an SDO write of one takes effect at the next SYNC
_TARGETS = {index for index, _ in TARGET_OF_MODE.values()} | {cia.DQ_VOLTAGE}
_SIGNED = (
    cia.MODES_OF_OPERATION,
    cia.QUICK_STOP_OPTION,
    cia.FAULT_REACTION_OPTION,
    cia.ABORT_CONNECTION_OPTION,
)
_QUICK_STOP_OPTIONS = frozenset(int(o) for o in QuickStopOption)
S = PowerState
# Module globals for the per-SYNC path: an enum member's lookup (or hash) takes ~0.2 us, a global's 0.03
_CSP, _CST = int(Mode.CSP), int(Mode.CST)
_ENABLED = S.OPERATION_ENABLED


@functools.lru_cache(maxsize=1)
def toolkit_profile() -> DeviceProfile:
    """The profile of the toolkit's own drive (``devices/drive-rig.toml``)."""
    return load_profile(DEVICES_DIR / "drive-rig.toml")


class EmulatedDrive(DriveCycle, DriveSafety, EmulatedNode):
    """A CiA 402 drive node with ``axis`` behind it; see the module docstring.

    ``profile``: the drive's device profile (default: the toolkit's own). ``shaft``: the plant
    the axis is part of (``plant_emulator.shaft``), shared with the other nodes on it; None
    gives the drive a shaft of its own.

    Parameters
    ----------
    node_id : int
        Its node.
    network : canopen.Network
        The canopen network it answers on.
    axis : Axis
        The physics behind it.
    period : float
        [s] the SYNC period.
    profile : DeviceProfile | None, optional
        The drive's device profile (None: the toolkit's own).
    shaft : Shaft | None, optional
        The shaft it is part of (None: one of its own).
    """

    def __init__(
        self,
        node_id: int,
        network: canopen.Network,
        axis: Axis,
        *,
        period: float,
        profile: DeviceProfile | None = None,
        shaft: Shaft | None = None,
    ) -> None:
        self._own(axis, period, profile, shaft)
        super().__init__(node_id, str(self.profile.eds), network)
        self.fixed_mapping = self.profile.mapping == "fixed"
        self.sdo_delay = self.profile.timing.sdo_response
        self._objects(self.node.object_dictionary)

    def _own(self, axis: Axis, period: float, profile: DeviceProfile | None, shaft: Shaft | None) -> None:
        """The drive's own state, before its node's (``plant_emulator.multi_axis`` shares a node)."""
        shaft = shaft or Shaft(axis, period=period)
        if axis not in shaft.axes:
            raise ValueError("the drive's axis must be one of its shaft's axes")
        if period != shaft.period:
            raise ValueError(f"the drive's period {period!r} s is not its shaft's, {shaft.period!r} s")
        self.profile = profile or toolkit_profile()
        self.axis, self.shaft, self.period = axis, shaft, period
        self._speed_limited = Mode.DQ_VOLTAGE not in axis.modes  # a grid converter has no speed
        self.sm = PowerStateMachine()
        self.braking = Braking()
        self._pending: list[Timed] = []
        self._t_sync = 0.0
        self.glitch_counts = 0  #: fault injection: added to the latched position [position units]
        self._sdo_target = False
        self.fault_code = 0
        self._pending_cw: int | None = None
        self._mode_switch: tuple[int, float] | None = None  #: (mode, device time [s] it shows)
        self.harmful_writes: list[tuple[int, int, bytes]] = []  #: (index, subindex, data)

    def _objects(self, od: Any) -> None:
        """What the drive takes from its object dictionary ``od`` (one axis's view on a drive of
        several), then its place on its shaft."""
        self._present = frozenset(od.indices)
        self.modes = self._modes(od)
        self._latency_object = self.profile.role_object("command-latency")
        ratings = Ratings(1.0, 1.0, 3000, 6000)  # until ``rate``: a preset rates every drive
        dq = hasattr(self.axis, "i_dq")
        self.image = ProcessImage(self.od, self._has, self.profile.units, ratings, dq=dq)
        self.profiles = ProfileModes(self.od, self._has, self.image, self.profile)
        self._following_since: float | None = None  #: device time [s] the following error began
        self._defaults()
        self.shaft.attach(self)

    def _has(self, index: int) -> bool:
        return index in self._present

    def _modes(self, od: Any) -> tuple[int, ...]:
        """The profile's modes the physics can run (profile modes need the loops they use)."""
        capable = set(self.axis.modes)
        if Mode.CSP in capable:
            capable |= {Mode.PROFILE_POSITION, Mode.HOMING, Mode.INTERPOLATED_POSITION}
        modes = tuple(int(m) for m in self.profile.check_against(od) if m in capable)
        if self._has(cia.SUPPORTED_MODES):
            self.write(cia.SUPPORTED_MODES, 0, sum(MODE_BITS[Mode(m)] for m in modes))
        return modes

    def _defaults(self) -> None:
        """The profile's reaction codes into the objects the drive has (its power-on values)."""
        r = self.profile.reactions
        for index, value in (
            (cia.QUICK_STOP_OPTION, r.quick_stop),
            (cia.FAULT_REACTION_OPTION, r.fault),
            (cia.ABORT_CONNECTION_OPTION, r.abort_connection),
            (cia.HALT_OPTION, r.halt),
        ):
            if self._has(index):
                self.write(index, 0, value)
        self.sm.quick_stop_option = self._option(cia.QUICK_STOP_OPTION, r.quick_stop)

    def _option(self, index: int, default: int) -> int:
        return int(self.read(index)) if self._has(index) else default

    @property
    def enabled(self) -> bool:
        """OPERATION ENABLED (or stopping in QUICK STOP ACTIVE): the drive has its axis."""
        return self.sm.state in (_ENABLED, S.QUICK_STOP_ACTIVE)

    @property
    def lockstep(self) -> bool:
        """True: an event RPDO counts as received at its SYNC, time is the SYNC count (lock-step across
        processes: arrival times are scheduling noise); False: they count. The shaft's: its nodes agree."""
        return self.shaft.lockstep

    @lockstep.setter
    def lockstep(self, value: bool) -> None:
        self.shaft.lockstep = value

    def rate(self, ratings: Ratings, *, counts_per_rev: int | None) -> None:
        """Take the ratings and the position resolution [increments/rev; None: the drive's own].

        Parameters
        ----------
        ratings : Ratings
            The motor's ratings.
        counts_per_rev : int | None
            [increments/rev] the position resolution (None: the drive's own).
        """
        self.image.rate(ratings, counts_per_rev)

    @property
    def counts_per_rad(self) -> float:
        """Position units per rad (increments for the toolkit's drive)."""
        return self.image.units.position

    # --- object writes -----------------------------------------------------
    def on_write(self, index: int, subindex: int, data: bytes) -> None:
        if index in self.profile.harmful:
            log.warning(
                "node %d: write of %s to 0x%04X:%d (%s)",
                self.node_id,
                data.hex(),
                index,
                subindex,
                next(m.name for m in self.profile.manufacturer if m.index == index),
            )
            self.harmful_writes.append((index, subindex, bytes(data)))
        value = int.from_bytes(data, "little", signed=index in _SIGNED)
        if index == cia.MODES_OF_OPERATION:
            self._select_mode(value)
        elif index == cia.QUICK_STOP_OPTION:
            if value not in _QUICK_STOP_OPTIONS:
                raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
            self.sm.quick_stop_option = value
        elif index == cia.CONTROLWORD:
            self.profiles.controlword(value)
            self._pending_cw = value
            if not self.in_rpdo:
                self._apply_controlword(value)
        elif index in IP_OBJECTS:  # interpolated position: its buffer (``plant_emulator.interpolation``)
            self._follow(self.profiles.ip.write(index, subindex, data, rpdo=self.in_rpdo))
        elif index in _TARGETS and not self.in_rpdo:
            self._sdo_target = True

    def after_write(self, index: int) -> None:
        if index in UNIT_OBJECTS:
            self.image.refresh()
        elif index == cia.INTERPOLATION_CONFIG:  # its buffer position shows the FIFO's fill
            self.profiles.ip.show()

    def _select_mode(self, mode: int) -> None:
        """0x6060: a mode of 0x6502 (else SDO abort 0x06090030), shown in 0x6061 after the
        profile's ``mode_switch`` time."""
        if mode not in self.modes:
            raise SdoAbortedError(SdoAbortCode.VALUE_RANGE_EXCEEDED)
        delay = self.profile.timing.mode_switch
        if delay > 0.0:
            self._mode_switch = (mode, self.shaft.t + delay)
        else:
            self._mode_switch = None
            self._show_mode(mode)

    def _show_mode(self, mode: int) -> None:
        """0x6061 takes ``mode``; an enabled drive's generators start from the motor's state."""
        self.write(cia.MODES_DISPLAY, 0, mode)
        if self.sm.state is _ENABLED:
            self._hold(mode)
        self.profiles.ip.track(self.sm.state is _ENABLED and mode == Mode.INTERPOLATED_POSITION)

    def _follow(self, demand: float | None) -> None:
        """A position demand [rad] the drive's interpolator took at once (a record it waited for)."""
        if demand is not None:
            self.axis.set_command(_CSP, complex(demand))

    def _hold(self, mode: int) -> None:
        """Entering ``mode`` enabled: CSP goes for 0x607A (absolute, CiA 402; a host that left a
        stale target there sees the motor go for it) or, with the profile's ``csp_enable =
        "hold"``, holds where it stands; the other cyclic modes start from zero speed/torque;
        profile modes start their generators here."""
        ax = self.axis
        if mode in PROFILE_MODES:
            self.profiles.start(ax.position, ax.velocity)
            ax.set_command(_CSP, complex(ax.position))
        elif mode == _CSP and mode in ax.modes:
            hold = self.profile.csp_enable == "hold"
            ax.set_command(mode, complex(ax.position) if hold else self._target(_CSP))
        elif mode in ax.modes:
            ax.set_command(mode, 0j)
        else:  # no mode selected: enabled, but no torque
            ax.coast()

    def _apply_controlword(self, cw: int) -> None:
        before = self.sm.state
        after = self.sm.command(cw)
        if after is before:
            return
        log.info("node %d: %s -> %s (controlword 0x%04X)", self.node_id, before.value, after.value, cw)
        if before is S.FAULT:
            self.fault_code = 0
            self.write(cia.ERROR_CODE, 0, EmcyCode.NO_ERROR)
            self.write(cia.ERROR_REGISTER, 0, 0)
            if self.nmt_state == OPERATIONAL:
                self.node.emcy.reset()
        if after is S.OPERATION_ENABLED:
            self._hold(self.read(cia.MODES_DISPLAY))
            if before is not S.QUICK_STOP_ACTIVE:
                self.shaft.enabled(self)
        self._latch_status()

    def on_rpdo(self, number: int, *, synchronous: bool) -> None:
        if self._pending_cw is not None:
            cw, self._pending_cw = self._pending_cw, None
            self._apply_controlword(cw)
        if self.sm.state is not _ENABLED:
            return
        mode = self.od.read(cia.MODES_DISPLAY, 0)
        if mode not in self.axis.modes or mode in PROFILE_MODES:
            return
        value = self._target(mode)
        if synchronous:
            self._pending.append((self.shaft.t, self.axis, mode, value, True))
            return
        if self._latency_object is not None:
            latency = self._u(self._latency_object, 0) * 1e-6  # us -> s
        else:
            latency = self.profile.timing.pdo_latency
        if self.shaft.clock is not None:  # real time: due a latency after it arrived
            self._pending.append((self.shaft.clock() + latency, self.axis, mode, value, False))
            return
        arrival = 0.0 if self.shaft.lockstep else self.rx_time - self._t_sync
        arrival = latency if 0.0 > arrival else arrival + latency  # max(arrival, 0.0) + latency
        due = self.shaft.t + (self.period if self.period < arrival else arrival)  # min(that, period)
        self._pending.append((due, self.axis, mode, value, False))

    def _target(self, mode: int) -> complex:
        """The target of a cyclic mode in SI, within 0x607D (CSP) or 0x6072 (CST)."""
        value = self.image.target(mode)
        if mode == _CSP:
            low, high = self.profiles.limits()
            return complex(min(max(value.real, low), high))
        if mode == _CST and self._has(cia.MAX_TORQUE):
            limit = self.od.read(cia.MAX_TORQUE, 0) / 1000.0 * self.image.rated_torque
            return complex(min(max(value.real, -limit), limit))
        return value

    def on_reset(self, *, application: bool) -> None:
        """Power-on or NMT reset node: the drive lets go of its axis; the shaft keeps turning.

        Parameters
        ----------
        application : bool
            Reset node (else power-on).
        """
        self.axis.release()
        self.sm = PowerStateMachine()
        self.sm.power_on()
        self._pending.clear()
        self._mode_switch = None
        self.fault_code = 0
        self.image.refresh()
        self.sm.quick_stop_option = self._option(cia.QUICK_STOP_OPTION, self.profile.reactions.quick_stop)
        self._latch_status()

    def sync_time(self, timestamp: float) -> float:
        return self.shaft.t if self.shaft.lockstep else super().sync_time(timestamp)
