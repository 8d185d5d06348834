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
CW = Controlword
_VOLTAGE_ON = (S.READY_TO_SWITCH_ON, S.SWITCHED_ON, S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE)
_POWER_ON = (S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE, S.FAULT_REACTION_ACTIVE)


def _is(cw: int, command: Controlword) -> bool:
    return cw & command.mask == command


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

    def power_on(self) -> PowerState:
        """Transitions 0 and 1: self-test done, to SWITCH ON DISABLED."""
        self.state = S.SWITCH_ON_DISABLED
        self._last_cw = 0
        return self.state

    def statusword(self) -> int:
        """Bits 0-6 for the present state, plus bit 4 voltage enabled where the power stage is on."""
        word = self.state.bits
        if self.state in _VOLTAGE_ON:
            word |= SW_VOLTAGE_ENABLED
        return word

    @property
    def power_stage_on(self) -> bool:
        """Torque may be produced (operation enabled, or a stopping reaction in progress)."""
        return self.state in _POWER_ON

    def fault(self) -> PowerState:
        """Transition 13: a fault from any state (reaction runs before FAULT)."""
        if self.state not in (S.FAULT, S.FAULT_REACTION_ACTIVE):
            self.state = S.FAULT_REACTION_ACTIVE
        return self.state

    def reaction_done(self) -> PowerState:
        """The stop ramp ended: transition 14 (to FAULT) or 12 (to SWITCH ON DISABLED, options 0-4)."""
        if self.state is S.FAULT_REACTION_ACTIVE:
            self.state = S.FAULT
        elif (
            self.state is S.QUICK_STOP_ACTIVE and self.quick_stop_option < QuickStopOption.SLOW_DOWN_RAMP_STAY
        ):
            self.state = S.SWITCH_ON_DISABLED
        return self.state

    def command(self, cw: int) -> PowerState:
        """Apply controlword ``cw`` (device control commands of CiA 402)."""
        rising_reset = _is(cw, CW.FAULT_RESET) and not _is(self._last_cw, CW.FAULT_RESET)
        self._last_cw = cw
        st = self.state
        if st is S.FAULT:
            if rising_reset:
                self.state = S.SWITCH_ON_DISABLED  # 15
            return self.state
        if st in (S.NOT_READY_TO_SWITCH_ON, S.FAULT_REACTION_ACTIVE):
            return st
        if _is(cw, CW.FAULT_RESET):
            return st  # fault reset bit outside FAULT: no command
        self.state = self._transition(st, cw)
        return self.state

    def _transition(self, st: PowerState, cw: int) -> PowerState:
        """Transitions 2-12 and 16 from ``st`` under controlword ``cw`` (bit 7 clear)."""
        disable_voltage = _is(cw, CW.DISABLE_VOLTAGE)
        quick_stop = _is(cw, CW.QUICK_STOP)
        shutdown = _is(cw, CW.SHUTDOWN)
        switch_on = _is(cw, CW.SWITCH_ON)
        enable = _is(cw, CW.ENABLE_OPERATION)
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
            if enable and self.quick_stop_option >= QuickStopOption.SLOW_DOWN_RAMP_STAY:
                return S.OPERATION_ENABLED  # 16
        return st
