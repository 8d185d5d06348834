"""Profile velocity, profile position (set-point handshake), homing, halt, the software position
limits, max torque and the following-error window and time of the zoo drives (CiA 402-2), with
canopen's RemoteNode as the host and each drive's own units."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from tests.plant_emulator.test_zoo_conformance import Twin

PP, PV, HM, CSP, CST = 1, 3, 6, 8, 10
BIT10, BIT11, BIT12, BIT13 = 1 << 10, 1 << 11, 1 << 12, 1 << 13


@pytest.fixture(params=["epos4", "nanotec-c5e", "tmcm-1160"])
def twin(request: pytest.FixtureRequest) -> Iterator[Twin]:
    t = Twin(request.param)
    yield t
    t.close()


def _sw(twin: Twin) -> int:
    return int(twin.node.sdo[0x6041].raw)


def _accel(twin: Twin, index: int, value: float) -> None:
    twin.node.sdo[index].raw = round(value * twin.per_rad_s())


def test_profile_velocity_ramps_and_halts(twin: Twin) -> None:
    node = twin.node
    twin.enable(PV)
    _accel(twin, 0x6083, 500.0)  # rad/s^2
    _accel(twin, 0x6084, 1000.0)
    node.sdo[0x60FF].raw = round(60.0 * twin.per_rad_s())
    twin.run(0.06)
    assert twin.drive.axis.velocity == pytest.approx(30.0, abs=2.0)  # half-way up the ramp
    assert not _sw(twin) & BIT10
    twin.run(0.2)
    assert twin.drive.axis.velocity == pytest.approx(60.0, rel=0.01)
    assert _sw(twin) & BIT10  # target reached
    node.sdo[0x605D].raw = 1  # halt on the profile deceleration
    node.sdo[0x6040].raw = 0x010F  # halt
    twin.run(0.03)
    assert twin.drive.axis.velocity == pytest.approx(30.0, abs=2.0)
    twin.run(0.1)
    assert abs(twin.drive.axis.velocity) < 0.2
    assert _sw(twin) & BIT12  # speed zero
    node.sdo[0x6040].raw = 0x000F  # halt released: back up to the target
    twin.run(0.3)
    assert twin.drive.axis.velocity == pytest.approx(60.0, rel=0.01)


def _new_setpoint(twin: Twin, target: float, cw: int = 0x0F) -> None:
    """The set-point handshake: bit 4 up, the drive acknowledges (bit 12), bit 4 down."""
    node = twin.node
    node.sdo[0x607A].raw = round(target * twin.per_rad())
    node.sdo[0x6040].raw = cw | 0x10
    assert _sw(twin) & BIT12 == 0  # not before the drive's cycle
    twin.run(twin.period)
    assert _sw(twin) & BIT12
    node.sdo[0x6040].raw = cw
    twin.run(twin.period)
    assert not _sw(twin) & BIT12


def test_profile_position_moves_with_the_handshake(twin: Twin) -> None:
    node = twin.node
    twin.enable(PP)
    _accel(twin, 0x6083, 500.0)
    _accel(twin, 0x6084, 500.0)
    node.sdo[0x6081].raw = round(50.0 * twin.per_rad_s())
    _new_setpoint(twin, 10.0)
    twin.run(0.1)  # accelerating: 0.1 s at 500 rad/s^2 reaches 50 rad/s after 2.5 rad
    assert twin.drive.profiles.move.velocity == pytest.approx(50.0, rel=2e-3)  # (rpm: quantised)
    assert twin.drive.axis.velocity == pytest.approx(50.0, abs=5.0)  # its position loop lags
    assert not _sw(twin) & BIT10
    twin.run(0.35)  # 0.1 + 0.2 cruise + 0.1 brake = 0.4 s in all
    assert twin.drive.axis.position == pytest.approx(10.0, abs=0.01)
    assert _sw(twin) & BIT10
    assert node.sdo[0x6064].raw == pytest.approx(10.0 * twin.per_rad(), abs=0.01 * twin.per_rad())
    _new_setpoint(twin, 5.0, cw=0x4F)  # relative: 5 rad more
    twin.run(0.5)
    assert twin.drive.axis.position == pytest.approx(15.0, abs=0.01)


def test_software_position_limits_clamp_the_target(twin: Twin) -> None:
    node = twin.node
    node.sdo[0x607D][2].raw = round(12.0 * twin.per_rad())
    twin.enable(PP)
    _new_setpoint(twin, 20.0)
    assert _sw(twin) & BIT11  # internal limit active
    twin.run(1.0)
    assert twin.drive.axis.position == pytest.approx(12.0, abs=0.01)


def test_homing_on_the_present_position_and_on_the_home_switch(twin: Twin) -> None:
    node = twin.node
    offset = round(1.0 * twin.per_rad())
    node.sdo[0x607C].raw = offset
    twin.enable(HM)
    node.sdo[0x6098].raw = 37
    node.sdo[0x6040].raw = 0x1F
    twin.run(twin.period)
    assert _sw(twin) & BIT12  # homing attained
    assert node.sdo[0x6064].raw == offset
    node.sdo[0x6040].raw = 0x0F
    # method 19: the switch is on at shaft angles >= 0.5 rad (the profile); the motor is near 0
    node.sdo[0x6098].raw = 19
    node.sdo[0x6040].raw = 0x1F
    twin.run(0.02)
    assert not _sw(twin) & BIT12
    assert twin.drive.axis.velocity > 5.0  # searching in the positive direction
    twin.run(1.0)
    assert _sw(twin) & BIT12 and not _sw(twin) & BIT13
    edge = twin.drive.axis.position
    assert edge == pytest.approx(0.5, abs=0.02)
    assert node.sdo[0x6064].raw == pytest.approx(offset, abs=0.02 * twin.per_rad())
    assert node.sdo[0x60FD].raw & 0x4 == (0x4 if edge >= 0.5 else 0)


def test_an_unsupported_homing_method_is_a_homing_error(twin: Twin) -> None:
    node = twin.node
    twin.enable(HM)
    node.sdo[0x6098].raw = 1  # (index pulse methods: no zoo drive has an index pulse)
    node.sdo[0x6040].raw = 0x1F
    twin.run(twin.period)
    assert _sw(twin) & BIT13


def test_following_error_window_and_time() -> None:
    """CSP: an error beyond 0x6065 faults (EMCY 0x8611) only after it lasted 0x6066 ms."""
    twin = Twin("faulhaber-mc5004")
    try:
        node = twin.node
        node.sdo[0x6065].raw = round(0.05 * twin.per_rad())  # 0.05 rad
        node.sdo[0x6066].raw = 10  # ms
        twin.enable(CSP)
        node.sdo[0x607A].raw = round(1.0 * twin.per_rad())  # a 1 rad step: the loop lags behind
        twin.run(0.008)
        assert twin.state().value == "OPERATION ENABLED"
        twin.run(0.005)
        assert twin.state().value in ("FAULT REACTION ACTIVE", "FAULT")
        assert node.sdo[0x603F].raw == 0x8611
    finally:
        twin.close()


def test_max_torque_limits_the_torque_target() -> None:
    twin = Twin("faulhaber-mc5004")
    try:
        node = twin.node
        node.sdo[0x6072].raw = 100  # per mille of the rated torque
        twin.enable(CST)
        node.sdo[0x6071].raw = 500
        twin.run(0.01)
        rated = node.sdo[0x6076].raw / 1000.0
        assert twin.drive.axis.torque == pytest.approx(0.1 * rated, rel=0.02)
        assert node.sdo[0x6077].raw == pytest.approx(100, abs=2)
        assert not math.isnan(rated)
    finally:
        twin.close()


def test_halt_stops_a_position_move_and_release_resumes_it(twin: Twin) -> None:
    """Halt in profile position: the move brakes to rest and resumes on release. Bit 10 with halt
    set says whether the axis is at rest: 0 while it decelerates, 1 once its speed is 0 (CiA 402
    profile position statusword, as drive manuals document it, e.g. Danfoss VLT servo, Applied
    Motion, LUST ServoOne)."""
    node = twin.node
    twin.enable(PP)
    _accel(twin, 0x6083, 500.0)
    _accel(twin, 0x6084, 500.0)
    node.sdo[0x6081].raw = round(50.0 * twin.per_rad_s())
    node.sdo[0x605D].raw = 1  # halt on the profile deceleration
    _new_setpoint(twin, 20.0)
    twin.run(0.2)
    node.sdo[0x6040].raw = 0x010F  # halt
    twin.run(0.02)
    assert abs(twin.drive.axis.velocity) > 10.0  # still braking (50 rad/s at 500 rad/s^2)
    assert not _sw(twin) & BIT10  # axis decelerates
    twin.run(0.3)
    halted = twin.drive.axis.position
    assert abs(twin.drive.axis.velocity) < 0.1 and halted < 15.0
    assert _sw(twin) & BIT10  # velocity of the axis is 0
    node.sdo[0x6040].raw = 0x000F
    twin.run(0.02)
    assert not _sw(twin) & BIT10  # moving on to the target
    twin.run(1.0)
    assert twin.drive.axis.position == pytest.approx(20.0, abs=0.01)
    assert _sw(twin) & BIT10


def test_following_error_in_profile_position() -> None:
    """Profile position: a move the motor cannot follow (its position loop is too slow for a
    2000 rad/s^2 profile at 0x6065 = 0.05 rad) faults with 0x8611."""
    twin = Twin("faulhaber-mc5004")
    try:
        node = twin.node
        node.sdo[0x6065].raw = round(0.05 * twin.per_rad())
        node.sdo[0x6066].raw = 0
        twin.enable(PP)
        _accel(twin, 0x6083, 2000.0)
        node.sdo[0x6081].raw = round(100.0 * twin.per_rad_s())
        _new_setpoint(twin, 10.0)
        twin.run(0.1)
        assert node.sdo[0x603F].raw == 0x8611
    finally:
        twin.close()
