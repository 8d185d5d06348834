"""The CiA 402 power state machine by itself, with controlwords and statuswords written out
from the standard's tables (not from drivers.maps.cia, so a misreading there cannot pass)."""

from __future__ import annotations

import itertools

import pytest

from drivers.maps.cia import PowerState
from plant_emulator.cia402_state import PowerStateMachine

S = PowerState
# statusword bits 0-6 and bit 4 (voltage enabled) of each state
WORDS = {
    S.SWITCH_ON_DISABLED: 0x40,
    S.READY_TO_SWITCH_ON: 0x31,
    S.SWITCHED_ON: 0x33,
    S.OPERATION_ENABLED: 0x37,
    S.QUICK_STOP_ACTIVE: 0x17,
    S.FAULT_REACTION_ACTIVE: 0x0F,
    S.FAULT: 0x08,
}


def reference(state: PowerState, cw: int, last_cw: int, option: int) -> PowerState:
    """The transitions of CiA 402-2 Table 'device control commands', written out independently."""
    if state is S.FAULT:
        return S.SWITCH_ON_DISABLED if cw & 0x80 and not last_cw & 0x80 else state
    if state is S.FAULT_REACTION_ACTIVE or cw & 0x80:
        return state
    low = cw & 0x0F
    if state is S.SWITCH_ON_DISABLED:
        return S.READY_TO_SWITCH_ON if low in (0x06, 0x0E) else state
    if state is S.READY_TO_SWITCH_ON:
        if low in (0x00, 0x01, 0x04, 0x05, 0x08, 0x09, 0x0C, 0x0D, 0x02, 0x03, 0x0A, 0x0B):
            return S.SWITCH_ON_DISABLED
        return {0x07: S.SWITCHED_ON, 0x0F: S.OPERATION_ENABLED}.get(low, state)
    if state is S.SWITCHED_ON:
        if not low & 0x02 or low & 0x06 == 0x02:
            return S.SWITCH_ON_DISABLED
        return {0x06: S.READY_TO_SWITCH_ON, 0x0E: S.READY_TO_SWITCH_ON, 0x0F: S.OPERATION_ENABLED}.get(
            low, state
        )
    if state is S.OPERATION_ENABLED:
        if not low & 0x02:
            return S.SWITCH_ON_DISABLED
        if low & 0x06 == 0x02:
            return S.QUICK_STOP_ACTIVE
        return {0x06: S.READY_TO_SWITCH_ON, 0x0E: S.READY_TO_SWITCH_ON, 0x07: S.SWITCHED_ON}.get(low, state)
    # QUICK STOP ACTIVE
    if not low & 0x02:
        return S.SWITCH_ON_DISABLED
    return S.OPERATION_ENABLED if low == 0x0F and option >= 5 else state


@pytest.mark.parametrize("option", [2, 6])
def test_every_controlword_sequence_of_two_from_every_state(option: int) -> None:
    """Each state, then any two controlwords (bits 0-3 and 7), repeated: the machine, with its
    shortcut for a controlword sent again, agrees with the table every step."""
    words = [*range(16), 0x80, 0x86, 0x8F]
    for start, (a, b) in itertools.product(WORDS, itertools.product(words, repeat=2)):
        sm = PowerStateMachine()
        sm.power_on()
        sm.state, sm.quick_stop_option = start, option
        state, last = start, 0
        for cw in (a, a, b, b, a):
            state, last = reference(state, cw, last, option), cw
            assert sm.command(cw) is state, (start, hex(a), hex(b))
            assert sm.statusword() == WORDS[state]


def test_reactions_and_option_changes_are_seen_after_a_settled_controlword() -> None:
    sm = PowerStateMachine()
    sm.power_on()
    for cw in (0x06, 0x0F):
        sm.command(cw)
    sm.quick_stop_option = 2
    assert sm.command(0x02) is S.QUICK_STOP_ACTIVE
    assert sm.command(0x0F) is S.QUICK_STOP_ACTIVE  # option 2: no transition 16
    sm.quick_stop_option = 6
    assert sm.command(0x0F) is S.OPERATION_ENABLED  # the same controlword, another option: 16
    assert sm.fault() is S.FAULT_REACTION_ACTIVE and sm.command(0x0F) is S.FAULT_REACTION_ACTIVE
    assert sm.reaction_done() is S.FAULT and sm.statusword() == 0x08
    assert sm.command(0x0F) is S.FAULT and sm.command(0x8F) is S.SWITCH_ON_DISABLED  # 15, rising edge
