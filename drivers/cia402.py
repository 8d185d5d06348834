"""Host-side CiA 402 drive: an ``AxisDriver`` on canopen's ``RemoteNode`` that adapts to the device.

It builds on ``RemoteNode`` (SDO client, NMT, EMCY consumer), not on ``BaseNode402``:
BaseNode402's fault reset always waits about 400 ms (canopen #261), it asserts on the NMT
state (#309), and a controlword mapped in a synchronous RPDO is only buffered until that
RPDO is transmitted. Here the controlword goes by SDO during state changes, and the host
loop transmits the RPDO once per cycle.

Set-up takes the drive as it is (``setup``), calling the axis's parts in turn:

- its identity (0x1000 must be a CiA 402 device, 0x1018) and modes (0x6502 where it has
  one: the configured mode must be there before 0x6060 is written) and its units
  (``drivers.cia402_units``: 0x608F/0x6091/0x6092/0x60A8/0x60A9, 0x6075/0x6076, else
  ``[axis.units]``): ``discovery``, ``drivers.cia402_discovery``;
- the mode: 0x6060 written (never read first: it may be write-only), then 0x6061 awaited
  for ``mode_timeout`` [s]: ``settings``, ``drivers.cia402_setup``;
- the process data (``mapping``, ``drivers.cia402_mapping``): ``pdo="remap"`` writes a mapping that fits the
  device (its PDOs, mappability, 64 bits) and falls back, with a warning, to
  ``pdo="device"`` when the device refuses; ``pdo="device"`` uses the mapping in force.
  Frames are decoded from the mapping in force (``drivers.cia402_process``).

No manufacturer object (0x2000-0x5FFF) is written, by SDO or in an RPDO, and no manufacturer
mode (negative, 0x6502 bits 16-31) is used, but on the toolkit's own drive, identified by its
0x1018 (vendor 0xDB1, product 0x402; ``drivers.cia402_access``). Set-up writes only entries the
EDS declares writable and reads the others. The cycle is ``drivers.cia402_cycle``'s: every
cycle ``supervise`` checks the statusword and, where mapped, 0x6061: a drive that leaves
OPERATION ENABLED or changes mode stops the run, named.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from typing import Any

import canopen

from drivers.base import AxisState, Feedback
from drivers.cia402_cycle import Cia402Cycle
from drivers.cia402_discovery import Cia402Discovery
from drivers.cia402_feedback import FEEDBACK_NAMES, feedback_problem
from drivers.cia402_mapping import Cia402Mapping
from drivers.cia402_setup import Cia402Setup
from drivers.cia402_states import DISABLED_STATES, PowerStates, power_state
from drivers.cia402_supervision import DriveSupervision
from drivers.cia402_units import DriveUnits
from drivers.errors import ConfigError, DeviceFault
from drivers.maps import CIA402_EDS, cia
from drivers.maps.cia import Mode, PowerState
from drivers.maps.cia402_needs import needed, require
from drivers.maps.emcy import emcy_text
from drivers.maps.mode_names import mode_code
from drivers.producer_watch import ACCELERATION_LIMITS, declared_acceleration

__all__ = ["DISABLED_STATES", "Cia402Axis", "DriveUnits", "power_state"]

log = logging.getLogger(__name__)


def _checked(name: str, mode: str, pdo: str, feedback: Iterable[str]) -> Mode:
    """The mode's code, once ``mode``, ``pdo`` and ``feedback`` are checked (ConfigError naming
    the axis where one is not an axis's)."""
    try:
        op_mode = mode_code(mode)
    except ValueError as exc:
        raise ConfigError(f"axis {name!r}: {exc}") from None
    if pdo not in ("remap", "device"):
        raise ConfigError(f"axis {name!r}: pdo = {pdo!r}: remap or device")
    problem = feedback_problem(feedback)
    if problem:
        raise ConfigError(f"axis {name!r}: {problem}")
    return op_mode


class Cia402Axis(Cia402Cycle):
    """A CiA 402 drive at ``node_id`` in ``mode`` (``drivers.base.AXIS_MODES``); SI in and out.

    Parameters
    ----------
    name, mode : str
        The axis's name and mode.
    network : canopen.Network
        The network of its node.
    node_id : int
        Its node id (1-127).
    eds : str or None
        The device's own EDS/DCF (None: the toolkit's generic one).
    units : Mapping[str, float] | None
        Factors the device may lack (``counts_per_rev``, ``position_unit``, ``velocity_unit``,
        ``rated_torque`` [N m], ``rated_current`` [A]).
    sync_rpdo : bool
        The RPDO acts at the next SYNC (one period of delay), else on receipt.
    latency : float
        [s] the toolkit's own drive acts on an RPDO this late, where not ``sync_rpdo``.
    heartbeat_timeout : float
        [s] the host's watch of the drive's heartbeat (0: none).
    pdo : str
        "remap" or "device" (see the module docstring).
    mode_timeout : float
        [s] how long 0x6061 may take to follow 0x6060.
    sdo_timeout, sdo_retries : float or None, int or None
        Of every SDO transfer (None: ``CanopenAxis``'s).
    host : tuple of (int, float) or None
        (host node id, time [s]) the drive's heartbeat consumer watches (``DriveSupervision``).
    abort_connection : int or None
        0x6007 (None: the drive's own).
    period : float
        [s] the SYNC period (0: not told).
    rpdo_deadline : float
        [s] without the command RPDO before the toolkit's drive stops itself (0: none).
    reset_fault : bool
        A drive found in FAULT at enable is reset (else refused).
    emcy_texts : Mapping[int, str] | None
        The device's own EMCY texts.
    feedback : iterable of str
        What the TPDOs carry (``drivers.cia402_feedback``; the position always): without
        "velocity" the velocity is the position's backward difference, 0 at the first.
    axis : int
        Which axis of a drive of several (``drivers.maps.logical``).
    """

    DISABLE_CONFIRM = 0.1  #: [s] a disable has for the statusword to show it

    def __init__(
        self,
        name: str,
        network: canopen.Network,
        node_id: int,
        *,
        mode: str,
        eds: str | None = None,
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
        rpdo_deadline: float = 0.0,
        reset_fault: bool = False,
        emcy_texts: Mapping[int, str] | None = None,
        feedback: Iterable[str] = FEEDBACK_NAMES,
        axis: int = 1,
    ) -> None:
        super().__init__(
            name,
            mode,
            network,
            node_id,
            op_mode=_checked(name, mode, pdo, feedback),
            maps=frozenset(feedback),
            period=period,
            states=PowerStates(self),
            eds=eds or CIA402_EDS,
            eds_given=eds is not None,
            heartbeat_timeout=heartbeat_timeout,
            sdo_timeout=sdo_timeout,
            sdo_retries=sdo_retries,
            axis=axis,
        )
        #: set-up's parts: what the drive is, its process data, its settings and mode
        self.discovery = Cia402Discovery(self, units)
        self.mapping = Cia402Mapping(self, pdo, sync_rpdo=sync_rpdo, latency=latency)
        self.settings = Cia402Setup(self, mode_timeout)
        #: the drive's watch of the host and of its commands (its part, ``drivers.cia402_supervision``)
        self.supervision = DriveSupervision(self, host, abort_connection, rpdo_deadline)
        self.reset_fault = reset_fault  #: a drive found in FAULT at enable is reset (else refused)
        self.emcy_texts = dict(emcy_texts or {})
        self._sent = False  #: an SDO download or an NMT command went to the drive

    def sdo_write(self, index: int, subindex: int, value: Any) -> None:
        """An SDO download, never to a manufacturer object (0x2000-0x5FFF) but on the toolkit's own
        drive (``guard_manufacturer``: a ConfigError before anything is sent).

        Parameters
        ----------
        index, subindex : int
            The object.
        value : Any
            What to write.
        """
        self.discovery.guard_manufacturer(index, f"an SDO download to 0x{index:04X}:{subindex:02X}")
        self._sent = True
        if not self.discovery.standard_write(index, subindex, value):  # the device's, met without its EDS
            super().sdo_write(index, subindex, value)

    def nmt(self, state: str) -> None:
        """Command the node's NMT state (and remember that something was sent).

        Parameters
        ----------
        state : str
            ``OPERATIONAL``, ``PRE-OPERATIONAL`` or ``STOPPED``.
        """
        self._sent = True
        super().nmt(state)

    def close(self) -> None:
        """Disable and release; a drive the host only read from (set-up refused it before anything
        was sent: a mode it lacks, a factor nobody gives) is left as it is, no controlword."""
        if not self._sent:
            if not self._closed:
                self._forget()
                self._release()
            return
        super().close()

    # --- set-up: its parts called in turn -------------------------------------------------------
    def setup(self) -> None:
        """Identity, modes, units, the drive's own RPDO where its mapping is fixed (all read: a
        refusal sends nothing), PRE-OPERATIONAL, mode, process data, OPERATIONAL (still disabled).
        A dictionary that lacks what the mode needs (``drivers.maps.cia402_needs``) is refused
        once the drive is identified, before anything is written."""
        self.discover()
        limits = [self.discovery.optional(index) for index in ACCELERATION_LIMITS]
        self.max_acceleration = declared_acceleration(limits, self.units.velocity)
        what = f"axis {self.name!r} ({self.where}) in mode {self.mode}"
        require(self.node.object_dictionary, needed(self.op_mode), source=self.eds, what=what)
        self.mapping.refuse_foreign_rpdo()
        self.nmt("PRE-OPERATIONAL")
        self.settings.set_mode(self.op_mode)
        self.data, self.measures, self._motion, self._plan = self.mapping.map_process_data()
        self.supervision.configure()
        self.nmt("OPERATIONAL")

    def discover(self, *, check_mode: bool = True) -> DriveUnits:
        """What the drive is (``Cia402Discovery.discover``), its units kept as ``units``.

        Parameters
        ----------
        check_mode : bool
            Check the mode against 0x6502 and require its factors (not in commissioning).

        Returns
        -------
        drivers.cia402_units.DriveUnits
            The drive's units.
        """
        self.units = self.discovery.discover(check_mode=check_mode)
        return self.units

    @property
    def toolkit_drive(self) -> bool:
        """The toolkit's own drive, positively identified by its 0x1018 (``Identity.toolkit``)."""
        return self.device_id.toolkit

    # --- state machine ---------------------------------------------------------------------------
    def read_power_state(self) -> PowerState:
        """The CiA 402 state, read by SDO (``PowerStates.read``).

        Returns
        -------
        PowerState
            What the statusword shows.
        """
        return self.states.read()

    def read_state(self) -> AxisState:
        return self.states.axis_state()

    def fault_text(self) -> str:
        """What the drive's 0x603F holds, in words.

        Returns
        -------
        str
            Its code and text, or that it has none.
        """
        code = self.discovery.optional(cia.ERROR_CODE)
        if code is None:
            return "no 0x603F"
        return f"0x603F = 0x{int(code):04X}, {emcy_text(int(code), self.emcy_texts)}"

    def enable(self, *, timeout: float = 1.0, mode: int | None = None) -> None:
        """Shutdown, switch on, enable operation (transitions 2, 3, 4), within ``timeout`` [s]; a
        drive in FAULT is reset first with ``reset_fault``, else refused, saying what 0x603F holds.
        The target the drive acts on at once in ``mode`` (None: the axis's) is set first, so it
        enables at rest where it stands, not at a target left from before (``hold_still``).

        Parameters
        ----------
        timeout : float
            [s] how long the enable may take.
        mode : int or None
            The mode whose target is held (None: the axis's).

        Raises
        ------
        DeviceFault
            The drive is in FAULT and ``reset_fault`` is not set.
        """
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
        self.settings.hold_still(self.op_mode if mode is None else int(mode))
        self.supervision.watch()
        self.states.enable(timeout)

    def fault_reset(self, *, timeout: float = 1.0) -> None:
        """Rising edge of controlword bit 7 (transition 15).

        Parameters
        ----------
        timeout : float
            [s] how long the reset may take.
        """
        self.states.fault_reset(timeout)

    def quick_stop(self) -> None:
        """Quick stop command (transition 11), by SDO so it acts now, and in the RPDO from now on
        (``keep_stopping``). The drive's watch of the host and of its commands stays: it is
        lifted only once the disable is confirmed (``disable``)."""
        self.states.quick_stop()

    def at_rest(self, fb: Feedback) -> bool:
        """After a quick stop: the statusword shows the ramp ended (SWITCH ON DISABLED, FAULT), or
        QUICK STOP ACTIVE with the motor at rest (0x605A options 5-8). The statusword of the last
        TPDO, or read by SDO when no new TPDO came since the last call (TPDOs may have stopped).

        Parameters
        ----------
        fb : Feedback
            The last feedback.

        Returns
        -------
        bool
            The drive is at rest.
        """
        return self.states.at_rest(fb)

    def disable(self) -> None:
        """Disable voltage (transitions 7, 9, 10, 12), confirmed by the statusword (SWITCH ON
        DISABLED, READY TO SWITCH ON or FAULT, read by SDO within ``DISABLE_CONFIRM`` [s]), and
        only then the drive's watch of the host's heartbeat (0x1016) and of its commands (the
        RPDO deadline) lifted. A disable not confirmed (the SDO lost, the drive still enabled)
        leaves both in place, so the drive stops itself once the host goes quiet, and raises
        CommunicationError saying so. Nothing on a node whose 0x1000 says it is no CiA 402 drive."""
        if self.discovery.not_a_drive:
            return
        self.states.disable(self.supervision.kept)
        self.supervision.unwatch()

    def sibling_watches(self) -> list[DriveSupervision]:
        """The supervision of the other CiA 402 axes on the node (``DriveSupervision.unwatch_host``).

        Returns
        -------
        list of DriveSupervision
            One for each other drive axis alive on the node.
        """
        return [a.supervision for a in self.siblings() if isinstance(a, Cia402Axis)]

    def _watched(self) -> bool:
        return not self.states.disabled or self.supervision.deadline_comm is not None
