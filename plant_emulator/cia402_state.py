"""The CiA 402 power drive state machine (CiA 402-2, 6.x "PDS FSA"), pure logic.

``PowerStateMachine.command(controlword)`` applies the controlword's device
control command (Table: bits 7, 3, 2, 1, 0) and returns the new state;
``statusword()`` gives bits 0-6 for the state. Quick stop and fault reactions
take time (a ramp), so QUICK_STOP_ACTIVE and FAULT_REACTION_ACTIVE are left by
``reaction_done()``, which the drive calls when the motor has stopped.
"""

from __future__ import annotations

import enum

__all__ = ["PowerState", "PowerStateMachine", "statusword_state"]


class PowerState(enum.Enum):
    NOT_READY_TO_SWITCH_ON = "NOT READY TO SWITCH ON"
    SWITCH_ON_DISABLED = "SWITCH ON DISABLED"
    READY_TO_SWITCH_ON = "READY TO SWITCH ON"
    SWITCHED_ON = "SWITCHED ON"
    OPERATION_ENABLED = "OPERATION ENABLED"
    QUICK_STOP_ACTIVE = "QUICK STOP ACTIVE"
    FAULT_REACTION_ACTIVE = "FAULT REACTION ACTIVE"
    FAULT = "FAULT"


S = PowerState
#: statusword bits 0-6: ready, switched on, op enabled, fault, voltage on, quick stop, switch on disabled
_STATUS = {
    S.NOT_READY_TO_SWITCH_ON: 0x0000,
    S.SWITCH_ON_DISABLED: 0x0040,
    S.READY_TO_SWITCH_ON: 0x0021,
    S.SWITCHED_ON: 0x0023,
    S.OPERATION_ENABLED: 0x0027,
    S.QUICK_STOP_ACTIVE: 0x0007,
    S.FAULT_REACTION_ACTIVE: 0x000F,
    S.FAULT: 0x0008,
}
_MASKS = [
    (0x4F, 0x00, S.NOT_READY_TO_SWITCH_ON),
    (0x4F, 0x40, S.SWITCH_ON_DISABLED),
    (0x6F, 0x21, S.READY_TO_SWITCH_ON),
    (0x6F, 0x23, S.SWITCHED_ON),
    (0x6F, 0x27, S.OPERATION_ENABLED),
    (0x6F, 0x07, S.QUICK_STOP_ACTIVE),
    (0x4F, 0x0F, S.FAULT_REACTION_ACTIVE),
    (0x4F, 0x08, S.FAULT),
]


def statusword_state(statusword: int) -> PowerState:
    """The state a statusword reports (CiA 402 statusword decoding)."""
    for mask, value, state in _MASKS:
        if statusword & mask == value:
            return state
    raise ValueError(f"statusword 0x{statusword:04X} encodes no CiA 402 state")


class PowerStateMachine:
    """States and transitions 0-16 of the CiA 402 power drive state machine.

    ``quick_stop_option`` is 0x605A: 0-4 end in SWITCH ON DISABLED after the
    stop (transition 12), 5-8 stay in QUICK STOP ACTIVE until enabled again
    (transition 16). ``voltage_enabled`` is statusword bit 4.
    """

    def __init__(self) -> None:
        self.state = S.NOT_READY_TO_SWITCH_ON
        self.quick_stop_option = 2
        self._last_cw = 0

    def power_on(self) -> PowerState:
        """Transitions 0 and 1: self-test done, to SWITCH ON DISABLED."""
        self.state = S.SWITCH_ON_DISABLED
        self._last_cw = 0
        return self.state

    def statusword(self) -> int:
        """Bits 0-6 for the present state, plus bit 4 voltage enabled where the power stage is on."""
        word = _STATUS[self.state]
        if self.state in (S.SWITCHED_ON, S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE, S.READY_TO_SWITCH_ON):
            word |= 0x0010
        return word

    @property
    def power_stage_on(self) -> bool:
        """Torque may be produced (operation enabled, or a stopping reaction in progress)."""
        return self.state in (S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE, S.FAULT_REACTION_ACTIVE)

    def fault(self) -> PowerState:
        """Transition 13: a fault from any state (reaction runs before FAULT)."""
        if self.state not in (S.FAULT, S.FAULT_REACTION_ACTIVE):
            self.state = S.FAULT_REACTION_ACTIVE
        return self.state

    def reaction_done(self) -> PowerState:
        """The stop ramp ended: transition 14 (to FAULT) or 12 (to SWITCH ON DISABLED, options 0-4)."""
        if self.state is S.FAULT_REACTION_ACTIVE:
            self.state = S.FAULT
        elif self.state is S.QUICK_STOP_ACTIVE and self.quick_stop_option <= 4:
            self.state = S.SWITCH_ON_DISABLED
        return self.state

    def command(self, cw: int) -> PowerState:
        """Apply controlword ``cw`` (device control commands of CiA 402)."""
        rising_reset = bool(cw & 0x80) and not (self._last_cw & 0x80)
        self._last_cw = cw
        st = self.state
        if st is S.FAULT:
            if rising_reset:
                self.state = S.SWITCH_ON_DISABLED  # 15
            return self.state
        if st in (S.NOT_READY_TO_SWITCH_ON, S.FAULT_REACTION_ACTIVE):
            return st
        if cw & 0x80:
            return st  # fault reset bit outside FAULT: no command
        disable_voltage = not (cw & 0x02)
        quick_stop = (cw & 0x06) == 0x02
        shutdown = (cw & 0x07) == 0x06
        switch_on = (cw & 0x0F) == 0x07
        enable = (cw & 0x0F) == 0x0F
        if st is S.SWITCH_ON_DISABLED:
            if shutdown:
                self.state = S.READY_TO_SWITCH_ON  # 2
        elif st is S.READY_TO_SWITCH_ON:
            if disable_voltage or quick_stop:
                self.state = S.SWITCH_ON_DISABLED  # 7
            elif switch_on:
                self.state = S.SWITCHED_ON  # 3
            elif enable:
                self.state = S.OPERATION_ENABLED  # 3 + 4
        elif st is S.SWITCHED_ON:
            if disable_voltage or quick_stop:
                self.state = S.SWITCH_ON_DISABLED  # 10
            elif shutdown:
                self.state = S.READY_TO_SWITCH_ON  # 6
            elif enable:
                self.state = S.OPERATION_ENABLED  # 4
        elif st is S.OPERATION_ENABLED:
            if disable_voltage:
                self.state = S.SWITCH_ON_DISABLED  # 9
            elif quick_stop:
                self.state = S.QUICK_STOP_ACTIVE  # 11
            elif shutdown:
                self.state = S.READY_TO_SWITCH_ON  # 8
            elif switch_on:
                self.state = S.SWITCHED_ON  # 5
        elif st is S.QUICK_STOP_ACTIVE:
            if disable_voltage:
                self.state = S.SWITCH_ON_DISABLED  # 12
            elif enable and self.quick_stop_option >= 5:
                self.state = S.OPERATION_ENABLED  # 16
        return self.state
