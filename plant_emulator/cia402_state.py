"""The CiA 402 power drive state machine (CiA 402-2, 6.x "PDS FSA"), pure logic.

``PowerStateMachine.command(controlword)`` applies the controlword's device
control command (bits 7, 3, 2, 1, 0) and returns the new state;
``statusword()`` gives bits 0-6 for the state. Quick stop and fault reactions
take time (a ramp), so QUICK_STOP_ACTIVE and FAULT_REACTION_ACTIVE are left by
``reaction_done()``, which the drive calls when the motor has stopped. States,
statusword bits and controlword commands are those of ``drivers.maps.cia``.
"""

from __future__ import annotations

from drivers.maps.cia import SW_VOLTAGE_ENABLED, Controlword, PowerState, QuickStopOption

__all__ = ["PowerState", "PowerStateMachine"]

S = PowerState
_VOLTAGE_ON = (S.READY_TO_SWITCH_ON, S.SWITCHED_ON, S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE)
_POWER_ON = (S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE, S.FAULT_REACTION_ACTIVE)
_STAY = QuickStopOption.SLOW_DOWN_RAMP_STAY  #: quick stop options from here on stay in QUICK STOP ACTIVE


def _bits(command: Controlword) -> tuple[int, int]:
    """(mask, value) of a device control command, as plain ints (checked on every controlword)."""
    return command.mask, int(command)


_DISABLE_VOLTAGE, _QUICK_STOP, _SHUTDOWN, _SWITCH_ON, _ENABLE, _FAULT_RESET = (
    _bits(c)
    for c in (
        Controlword.DISABLE_VOLTAGE,
        Controlword.QUICK_STOP,
        Controlword.SHUTDOWN,
        Controlword.SWITCH_ON,
        Controlword.ENABLE_OPERATION,
        Controlword.FAULT_RESET,
    )
)


def _is(cw: int, command: tuple[int, int]) -> bool:
    return cw & command[0] == command[1]


class PowerStateMachine:
    """States and transitions 0-16 of the CiA 402 power drive state machine.

    ``quick_stop_option`` is 0x605A: 0-4 end in SWITCH ON DISABLED after the
    stop (transition 12), 5-8 stay in QUICK STOP ACTIVE until enabled again
    (transition 16). ``voltage_enabled`` is statusword bit 4.
    """

    def __init__(self) -> None:
        self.state = S.NOT_READY_TO_SWITCH_ON
        self.quick_stop_option = int(QuickStopOption.QUICK_STOP_RAMP)
        self._last_cw = 0
        self._settled: tuple[int, PowerState, int] | None = None  # (cw, state, option) that changed nothing
        self._word_state: PowerState | None = None
        self._word = 0

    def power_on(self) -> PowerState:
        """Transitions 0 and 1: self-test done, to SWITCH ON DISABLED.

        Returns
        -------
        PowerState
            SWITCH ON DISABLED.
        """
        self.state = S.SWITCH_ON_DISABLED
        self._last_cw = 0
        self._settled = None
        return self.state

    def statusword(self) -> int:
        """Bits 0-6 for the present state, plus bit 4 voltage enabled where the power stage is on.

        Returns
        -------
        int
            The statusword's state bits.
        """
        st = self.state
        if st is not self._word_state:  # decoded once per state change
            self._word_state = st
            self._word = st.bits | (SW_VOLTAGE_ENABLED if st in _VOLTAGE_ON else 0)
        return self._word

    @property
    def power_stage_on(self) -> bool:
        """Torque may be produced (operation enabled, or a stopping reaction in progress)."""
        return self.state in _POWER_ON

    def fault(self) -> PowerState:
        """Transition 13: a fault from any state (reaction runs before FAULT).

        Returns
        -------
        PowerState
            FAULT REACTION ACTIVE (or FAULT where it is one already).
        """
        if self.state not in (S.FAULT, S.FAULT_REACTION_ACTIVE):
            self.state = S.FAULT_REACTION_ACTIVE
        return self.state

    def quick_stop(self) -> PowerState:
        """The drive's own quick stop (transition 11, from OPERATION ENABLED only).

        Returns
        -------
        PowerState
            The new state.
        """
        if self.state is S.OPERATION_ENABLED:
            self.state = S.QUICK_STOP_ACTIVE
            self._settled = None
        return self.state

    def disable_voltage(self) -> PowerState:
        """The drive's own disable voltage (transitions 7, 9, 10, 12): the power stage off.

        Returns
        -------
        PowerState
            The new state.
        """
        if self.state in _VOLTAGE_ON:
            self.state = S.SWITCH_ON_DISABLED
            self._settled = None
        return self.state

    def reaction_done(self) -> PowerState:
        """The stop ramp ended: transition 14 (to FAULT) or 12 (to SWITCH ON DISABLED, options 0-4).

        Returns
        -------
        PowerState
            The new state.
        """
        if self.state is S.FAULT_REACTION_ACTIVE:
            self.state = S.FAULT
        elif self.state is S.QUICK_STOP_ACTIVE and self.quick_stop_option < _STAY:
            self.state = S.SWITCH_ON_DISABLED
        return self.state

    def command(self, cw: int) -> PowerState:
        """Apply controlword ``cw`` (device control commands of CiA 402).

        A controlword sent again (every cycle, in a PDO) to a state it left as it was
        changes nothing again: that case returns at once.

        Parameters
        ----------
        cw : int
            The controlword.

        Returns
        -------
        PowerState
            The new state.
        """
        st = self.state
        key = (cw, st, self.quick_stop_option)
        if key == self._settled:
            return st
        rising_reset = _is(cw, _FAULT_RESET) and not _is(self._last_cw, _FAULT_RESET)
        self._last_cw = cw
        if st is S.FAULT:
            if rising_reset:
                self.state = S.SWITCH_ON_DISABLED  # 15
        elif st not in (S.NOT_READY_TO_SWITCH_ON, S.FAULT_REACTION_ACTIVE) and not _is(cw, _FAULT_RESET):
            self.state = self._transition(st, cw)  # (the fault reset bit outside FAULT: no command)
        self._settled = key if self.state is st else None
        return self.state

    def _transition(self, st: PowerState, cw: int) -> PowerState:
        """Transitions 2-12 and 16 from ``st`` under controlword ``cw`` (bit 7 clear)."""
        disable_voltage = _is(cw, _DISABLE_VOLTAGE)
        quick_stop = _is(cw, _QUICK_STOP)
        shutdown = _is(cw, _SHUTDOWN)
        switch_on = _is(cw, _SWITCH_ON)
        enable = _is(cw, _ENABLE)
        if st is S.SWITCH_ON_DISABLED:
            if shutdown:
                return S.READY_TO_SWITCH_ON  # 2
        elif st is S.READY_TO_SWITCH_ON:
            if disable_voltage or quick_stop:
                return S.SWITCH_ON_DISABLED  # 7
            if switch_on:
                return S.SWITCHED_ON  # 3
            if enable:
                return S.OPERATION_ENABLED  # 3 + 4
        elif st is S.SWITCHED_ON:
            if disable_voltage or quick_stop:
                return S.SWITCH_ON_DISABLED  # 10
            if shutdown:
                return S.READY_TO_SWITCH_ON  # 6
            if enable:
                return S.OPERATION_ENABLED  # 4
        elif st is S.OPERATION_ENABLED:
            if disable_voltage:
                return S.SWITCH_ON_DISABLED  # 9
            if quick_stop:
                return S.QUICK_STOP_ACTIVE  # 11
            if shutdown:
                return S.READY_TO_SWITCH_ON  # 8
            if switch_on:
                return S.SWITCHED_ON  # 5
        elif st is S.QUICK_STOP_ACTIVE:
            if disable_voltage:
                return S.SWITCH_ON_DISABLED  # 12
            if enable and self.quick_stop_option >= _STAY:
                return S.OPERATION_ENABLED  # 16
        return st
