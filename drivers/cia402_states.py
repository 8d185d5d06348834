"""The CiA 402 state machine of a drive on the host, a part of ``drivers.cia402.Cia402Axis``.

``PowerStates`` reads the drive's state (its statusword by SDO), steps it towards a target by
controlword (CiA 402-2, 6.2: shutdown, switch on, enable operation; fault reset; quick stop;
disable voltage) and owns what the axis's cycle needs of it: the controlword a stop sends in the
RPDO from then on (``stop_word``), whether the last disable was confirmed, and the statusword's
stamp at the enable (the cycle's supervision looks at samples after it). What it needs of its
axis is ``StatedAxis``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Protocol

from drivers.base import AxisState, Feedback
from drivers.cia402_plan import SW
from drivers.cia402_process import ProcessData
from drivers.errors import CommunicationError, CommunicationTimeout, DeviceFault, RigError
from drivers.maps import cia
from drivers.maps.cia import Controlword, PowerState

__all__ = ["DISABLED_STATES", "TOWARDS_ENABLED", "PowerStates", "power_state"]

#: the controlword that moves one step towards OPERATION ENABLED from each state
TOWARDS_ENABLED = {
    PowerState.SWITCH_ON_DISABLED: Controlword.SHUTDOWN,
    PowerState.READY_TO_SWITCH_ON: Controlword.SWITCH_ON,
    PowerState.SWITCHED_ON: Controlword.ENABLE_OPERATION,
    PowerState.QUICK_STOP_ACTIVE: Controlword.DISABLE_VOLTAGE,
}
#: the states a disable must reach before the drive's supervision is relaxed: the drive function
#: off (CiA 402-2, 6.2), confirmed by the statusword
DISABLED_STATES = frozenset({PowerState.SWITCH_ON_DISABLED, PowerState.READY_TO_SWITCH_ON, PowerState.FAULT})
_AXIS_STATE = {
    PowerState.OPERATION_ENABLED: AxisState.ENABLED,
    PowerState.QUICK_STOP_ACTIVE: AxisState.STOPPING,
    PowerState.FAULT_REACTION_ACTIVE: AxisState.STOPPING,
    PowerState.FAULT: AxisState.FAULT,
}


def power_state(statusword: int) -> PowerState:
    """The state a statusword reports.

    Parameters
    ----------
    statusword : int
        0x6041.

    Returns
    -------
    PowerState
        Its state; NOT READY TO SWITCH ON for a word no state matches.
    """
    return cia.decode_statusword(statusword) or PowerState.NOT_READY_TO_SWITCH_ON


class StatedAxis(Protocol):
    """What the state machine needs of its axis (``drivers.cia402.Cia402Axis``)."""

    node_id: int
    data: ProcessData | None
    rest_speed: float
    DISABLE_CONFIRM: float
    idle: Callable[[], None]

    @property
    def where(self) -> str:
        """``node 5`` (and the axis on a drive of several), for messages."""

    def sdo_read(self, index: int, subindex: int = 0) -> Any:
        """An object's value, read by SDO."""

    def sdo_write(self, index: int, subindex: int, value: Any) -> None:
        """An SDO download."""


class PowerStates:
    """The drive's CiA 402 state machine, stepped by SDO.

    Parameters
    ----------
    axis : StatedAxis
        The axis whose drive it steps.
    """

    def __init__(self, axis: StatedAxis) -> None:
        self.axis = axis
        #: the controlword the RPDO carries from a stop on (quick stop, disable voltage); None:
        #: enable operation (set by ``quick_stop`` and ``disable``, cleared by ``enabling``)
        self.stop_word: int | None = None
        self.disabled = False  #: the statusword confirmed the last disable (``disable``)
        self.enabled_stamp: float | None = None  #: the statusword TPDO's stamp at the enable
        self.rest_stamp: float | None = None  #: the statusword TPDO's stamp at the last ``at_rest``

    def read(self) -> PowerState:
        """The CiA 402 state, read by SDO.

        Returns
        -------
        PowerState
            What the statusword shows.
        """
        return power_state(self.axis.sdo_read(cia.STATUSWORD))

    def axis_state(self) -> AxisState:
        """The drive's state as the driver contract names it.

        Returns
        -------
        AxisState
            ENABLED, STOPPING, FAULT, or DISABLED for the other states.
        """
        return _AXIS_STATE.get(self.read(), AxisState.DISABLED)

    def drive_to(self, target: PowerState, step: Callable[[PowerState], int | None], timeout: float) -> None:
        """Step the drive until it shows ``target``.

        Parameters
        ----------
        target : PowerState
            Where to.
        step : callable
            The controlword to write in each state it shows (None: none).
        timeout : float
            [s] how long it may take.

        Raises
        ------
        DeviceFault
            The drive went to FAULT on the way (but to SWITCH ON DISABLED).
        CommunicationTimeout
            It did not get there within ``timeout``.
        """
        axis = self.axis
        deadline = time.monotonic() + timeout
        while True:
            state = self.read()
            if state is target:
                return
            if state is PowerState.FAULT and target is not PowerState.SWITCH_ON_DISABLED:
                raise DeviceFault(f"drive in FAULT while going to {target.value}", device=axis.where)
            cw = step(state)
            if cw is not None:
                axis.sdo_write(cia.CONTROLWORD, 0, int(cw))
            if time.monotonic() > deadline:
                raise CommunicationTimeout(
                    f"node {axis.node_id}: still {state.value} after {timeout:g} s, wanted {target.value}"
                )

    def enable(self, timeout: float) -> None:
        """Shutdown, switch on, enable operation (transitions 2, 3, 4), with no stop in force.

        Parameters
        ----------
        timeout : float
            [s] how long it may take.
        """
        self.stop_word, self.disabled = None, False
        self.drive_to(PowerState.OPERATION_ENABLED, TOWARDS_ENABLED.get, timeout)
        data = self.axis.data
        slot = data.slot_of(SW) if data else None
        self.enabled_stamp = slot.timestamp if slot else None

    def fault_reset(self, timeout: float) -> None:
        """A rising edge of controlword bit 7 (transition 15), where the drive is in FAULT.

        Parameters
        ----------
        timeout : float
            [s] how long it may take to show SWITCH ON DISABLED.
        """
        if self.read() is not PowerState.FAULT:
            return
        self.axis.sdo_write(cia.CONTROLWORD, 0, int(Controlword.DISABLE_VOLTAGE))
        self.drive_to(
            PowerState.SWITCH_ON_DISABLED,
            lambda s: Controlword.FAULT_RESET if s is PowerState.FAULT else None,
            timeout,
        )

    def quick_stop(self) -> None:
        """Quick stop (transition 11), by SDO so it acts now, and in the RPDO from now on."""
        self.stop_word = int(Controlword.QUICK_STOP)
        self.axis.sdo_write(cia.CONTROLWORD, 0, int(Controlword.QUICK_STOP))

    def disable(self, kept: Callable[[], str]) -> None:
        """Disable voltage (transitions 7, 9, 10, 12), confirmed by the statusword.

        Parameters
        ----------
        kept : callable
            What the drive still watches, in words, for a disable not confirmed.

        Raises
        ------
        CommunicationError
            The statusword did not show the drive disabled within the axis's ``DISABLE_CONFIRM``
            [s], or could not be read.
        """
        axis = self.axis
        self.stop_word = int(Controlword.DISABLE_VOLTAGE)
        try:
            axis.sdo_write(cia.CONTROLWORD, 0, int(Controlword.DISABLE_VOLTAGE))
            state = self._confirm_disabled()
        except RigError as exc:
            raise CommunicationError(
                f"{axis.where}: disable voltage not confirmed ({exc}); {kept()}"
            ) from exc
        if state not in DISABLED_STATES:
            raise CommunicationError(
                f"{axis.where}: disable voltage not confirmed: the statusword shows {state.value} "
                f"{axis.DISABLE_CONFIRM:g} s after it; {kept()}"
            )
        self.disabled = True

    def _confirm_disabled(self) -> PowerState:
        """The state the statusword shows, read until it shows the drive disabled or
        ``DISABLE_CONFIRM`` [s] have passed (time passing by ``idle``)."""
        deadline = time.monotonic() + self.axis.DISABLE_CONFIRM
        while True:
            state = self.read()
            if state in DISABLED_STATES or time.monotonic() > deadline:
                return state
            self.axis.idle()

    def at_rest(self, fb: Feedback) -> bool:
        """After a quick stop: the ramp ended, or the motor is at rest in QUICK STOP ACTIVE.

        The statusword of the last TPDO, or read by SDO when no new TPDO came since the last call
        (TPDOs may have stopped).

        Parameters
        ----------
        fb : Feedback
            The last feedback (its velocity, in QUICK STOP ACTIVE, 0x605A options 5-8).

        Returns
        -------
        bool
            SWITCH ON DISABLED, FAULT or NOT READY, or QUICK STOP ACTIVE below ``rest_speed``.
        """
        axis, data = self.axis, self.axis.data
        slot = data.slot_of(SW) if data is not None else None
        if data is not None and slot is not None and slot.timestamp not in (None, self.rest_stamp):
            self.rest_stamp = slot.timestamp
            word = data.value(SW)
        else:
            word = axis.sdo_read(cia.STATUSWORD)
        state = power_state(word)
        if state in (PowerState.SWITCH_ON_DISABLED, PowerState.FAULT, PowerState.NOT_READY_TO_SWITCH_ON):
            return True
        return state is PowerState.QUICK_STOP_ACTIVE and abs(fb.velocity) < axis.rest_speed
