"""The emulated drive stops as CiA 402 says a drive does: along the ramp its option code selects.

The peer is canopen's RemoteNode (SDO writes of the controlword), not drive-rig's driver.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import canopen
import pytest

from drivers.maps import CIA402_EDS
from drivers.maps.cia import PowerState as S
from plant_emulator.axes import DcServoAxis
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.lockstep import LockstepBench
from tests.plant_emulator.test_canopen_devices import statusword_state

CPR = 4096  #: the dc-servo preset's increments per revolution
PERIOD = 0.4e-3
V0 = 100.0  #: [rad/s]


@pytest.fixture
def running() -> Iterator[tuple[LockstepBench, canopen.RemoteNode, EmulatedDrive]]:
    """The dc-servo drive in CSV at V0, enabled."""
    bench = LockstepBench("dc-servo")
    node = canopen.RemoteNode(1, CIA402_EDS)
    bench.host.add_node(node)
    node.nmt.state = "OPERATIONAL"
    node.sdo[0x6060].raw = 9  # CSV
    for cw in (0x06, 0x0F):
        node.sdo[0x6040].raw = cw
    node.sdo[0x60FF].raw = round(V0 * CPR / (2 * math.pi))
    drive = bench.devices[0]
    assert isinstance(drive, EmulatedDrive)
    _run(bench, 0.3)
    assert drive.axis.velocity == pytest.approx(V0, rel=1e-3)
    yield bench, node, drive
    bench.close()


def _run(bench: LockstepBench, seconds: float) -> None:
    for _ in range(round(seconds / PERIOD)):
        bench.sync()


def _state(node: canopen.RemoteNode) -> S:
    return statusword_state(node.sdo[0x6041].raw)


def coasted(drive: EmulatedDrive, w0: float, t: float) -> float:
    """The speed [rad/s] a motor at ``w0`` > 0 has after coasting ``t`` [s] on its friction alone,
    J dw/dt = -B w - T_c (the preset's viscous B and Coulomb T_c), solved here (0 once at rest)."""
    axis = drive.axis
    assert isinstance(axis, DcServoAxis)
    j, b, t_c = axis.motor.j, axis.motor.b, axis.coulomb
    return max(0.0, (w0 + t_c / b) * math.exp(-b * t / j) - t_c / b)


def _speeds(bench: LockstepBench, drive: EmulatedDrive, seconds: float) -> list[float]:
    out = []
    for _ in range(round(seconds / PERIOD)):
        bench.sync()
        out.append(drive.axis.velocity)
    return out


@pytest.mark.parametrize(("option", "index"), [(2, 0x6085), (1, 0x6084)])
def test_quick_stop_brakes_along_the_ramp_then_disables(running, option: int, index: int) -> None:  # type: ignore[no-untyped-def]
    """Options 1 and 2 of 0x605A: the speed falls at 0x6084 or 0x6085, then SWITCH ON DISABLED."""
    bench, node, drive = running
    decel = 2000.0  # rad/s^2
    node.sdo[index].raw = round(decel * CPR / (2 * math.pi))
    node.sdo[0x605A].raw = option
    node.sdo[0x6040].raw = 0x0B  # quick stop (transition 11)
    assert _state(node) is S.QUICK_STOP_ACTIVE
    speeds = _speeds(bench, drive, 0.02)
    # the speed loop follows the ramp: after 20 ms, 40 rad/s less (within its tracking lag)
    assert speeds[-1] == pytest.approx(V0 - decel * 0.02, abs=3.0)
    _run(bench, 0.1)  # the ramp ends at 50 ms; the speed loop settles within 40 ms more
    assert abs(drive.axis.velocity) < 0.05
    assert _state(node) is S.SWITCH_ON_DISABLED


def test_quick_stop_option_6_holds_in_quick_stop_active(running) -> None:  # type: ignore[no-untyped-def]
    bench, node, drive = running
    node.sdo[0x605A].raw = 6
    node.sdo[0x6040].raw = 0x0B
    _run(bench, 0.2)
    assert abs(drive.axis.velocity) < 0.05
    assert _state(node) is S.QUICK_STOP_ACTIVE
    node.sdo[0x6040].raw = 0x0F  # transition 16: back to OPERATION ENABLED
    assert _state(node) is S.OPERATION_ENABLED


def test_option_0_and_disable_during_the_ramp_coast(running) -> None:  # type: ignore[no-untyped-def]
    """Option 0 switches the power off; so does disable voltage in QUICK STOP ACTIVE (transition 12):
    the motor coasts, slowed by its friction alone (32 rad/s^2 of the preset's Coulomb friction,
    not the ramp's 0x6085). This is what a host that sends disable right after quick stop gets."""
    bench, node, drive = running
    node.sdo[0x605A].raw = 2
    node.sdo[0x6040].raw = 0x0B
    node.sdo[0x6040].raw = 0x00  # disable voltage at once
    assert _state(node) is S.SWITCH_ON_DISABLED
    _run(bench, 0.1)
    assert drive.axis.velocity == pytest.approx(coasted(drive, V0, 0.1), rel=1e-3)  # coasting, not braked
    assert drive.axis.velocity < V0 - 3.0  # (friction: 3.8 rad/s in 0.1 s)


def test_quick_stop_option_0_coasts(running) -> None:  # type: ignore[no-untyped-def]
    bench, node, drive = running
    node.sdo[0x605A].raw = 0
    node.sdo[0x6040].raw = 0x0B
    _run(bench, 0.1)
    assert _state(node) is S.SWITCH_ON_DISABLED
    assert drive.axis.velocity == pytest.approx(coasted(drive, V0, 0.1), rel=1e-3)


def test_fault_reaction_brakes_along_0x605e_then_fault(running) -> None:  # type: ignore[no-untyped-def]
    bench, node, drive = running
    decel = 1000.0
    node.sdo[0x6085].raw = round(decel * CPR / (2 * math.pi))
    node.sdo[0x605E].raw = 2  # quick stop ramp
    drive.raise_fault(0x8400)
    assert _state(node) is S.FAULT_REACTION_ACTIVE
    speeds = _speeds(bench, drive, 0.05)
    assert speeds[-1] == pytest.approx(V0 - decel * 0.05, abs=3.0)
    assert _state(node) is S.FAULT_REACTION_ACTIVE  # still braking
    _run(bench, 0.1)
    assert abs(drive.axis.velocity) < 0.05
    assert _state(node) is S.FAULT


@pytest.mark.parametrize(("reaction", "coasts"), [(0, True), (1, False)])
def test_a_fault_during_a_quick_stop_takes_the_fault_reaction(running, reaction: int, coasts: bool) -> None:  # type: ignore[no-untyped-def]
    """A fault in QUICK STOP ACTIVE is transition 13: from then on the drive reacts as 0x605E
    says, not along the quick stop's ramp. With 0x605E = 0 the power goes off at once and the
    motor coasts on its friction; with 1 it brakes at 0x6084."""
    bench, node, drive = running
    node.sdo[0x6085].raw = round(200.0 * CPR / (2 * math.pi))  # a slow quick stop ramp
    node.sdo[0x6084].raw = round(2000.0 * CPR / (2 * math.pi))  # a fast profile deceleration
    node.sdo[0x605A].raw = 2
    node.sdo[0x605E].raw = reaction
    node.sdo[0x6040].raw = 0x0B
    _run(bench, 0.02)  # the quick stop ramp: 4 rad/s off
    speed = drive.axis.velocity
    drive.raise_fault(0x2310)
    _run(bench, 0.03)
    if coasts:
        assert _state(node) is S.FAULT
        assert drive.axis.velocity == pytest.approx(coasted(drive, speed, 0.03), rel=1e-3)
    else:
        assert drive.axis.velocity == pytest.approx(speed - 2000.0 * 0.03, abs=3.0)  # 0x6084's


@pytest.mark.parametrize("before", [0x00, 0x06, 0x07])  # SWITCH ON DISABLED, READY TO SWITCH ON, SWITCHED ON
def test_a_fault_while_disabled_is_fault_at_once_and_the_motor_coasts(running, before: int) -> None:  # type: ignore[no-untyped-def]
    """A drive whose function is disabled gives no torque: a fault then (a shaft spun past 0x6080
    by its load, a supply fault) has no ramp to brake along. The fault reaction ends at once
    (transition 14, FAULT) and the motor coasts on its friction, whatever 0x605E says."""
    bench, node, drive = running
    node.sdo[0x605E].raw = 2  # quick stop ramp: what an enabled drive would brake along
    node.sdo[0x6040].raw = before
    speed = drive.axis.velocity
    drive.raise_fault(0x8400)
    assert _state(node) is S.FAULT
    _run(bench, 0.05)
    assert drive.axis.velocity == pytest.approx(coasted(drive, speed, 0.05), rel=1e-3)
