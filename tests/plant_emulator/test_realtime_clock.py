"""Real time: the emulated world runs on its own clock (injected here), never on frame arrival."""

from __future__ import annotations

import math
from collections.abc import Iterator

import canopen
import pytest

from drivers.maps import CIA402_EDS
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.clock import WorldClock
from plant_emulator.lockstep import SyncHub, attach_network
from plant_emulator.presets import build_preset

CPR = 4096


class World:
    """The dc-servo preset on an in-process bus, on a clock the test moves."""

    def __init__(self, start: float = 0.0, **params: object) -> None:
        self.time = start
        self.hub = SyncHub()
        self.host, self.dev = canopen.Network(), canopen.Network()
        attach_network(self.host, self.hub.bus(queue=False, channel="host"))
        attach_network(self.dev, self.hub.bus(queue=False, channel="device"))
        self.frames: list[int] = []
        self.hub.taps.append(lambda m: self.frames.append(m.arbitration_id))
        devices, self.period = build_preset("dc-servo", self.dev, params)
        for d in devices:
            d.boot()
        drive = devices[0]
        assert isinstance(drive, EmulatedDrive)
        self.drive = drive
        self.clock = WorldClock(devices, lambda: self.time)
        self.node = canopen.RemoteNode(1, CIA402_EDS)
        self.host.add_node(self.node)

    def wait(self, seconds: float, *, sync_every: float = 0.0) -> None:
        """Let ``seconds`` pass in 1 ms steps of the emulator's loop; a SYNC every ``sync_every``."""
        steps = round(seconds / 1e-3)
        every = round(sync_every / 1e-3) if sync_every else 0
        for k in range(steps):
            self.time += 1e-3
            self.hub.clock = self.time
            self.clock.advance()
            if every and k % every == 0:
                self.host.send_message(0x80, b"")

    def enable(self, mode: int) -> None:
        self.node.nmt.state = "OPERATIONAL"
        self.node.sdo[0x6060].raw = mode
        for cw in (0x06, 0x0F):
            self.node.sdo[0x6040].raw = cw

    def close(self) -> None:
        for net in (self.host, self.dev):
            net.bus.shutdown()


@pytest.fixture
def world() -> Iterator[World]:
    w = World()
    yield w
    w.close()


def test_time_passes_without_a_sync(world: World) -> None:
    """No SYNC at all: the motor still runs its second (after a SIGKILL of the host, a drive on
    its own clock is where its clock says, and its supervision runs on that clock too)."""
    world.enable(9)  # CSV
    world.node.sdo[0x60FF].raw = round(50.0 * CPR / (2 * math.pi))
    world.wait(1.0)
    assert 0x80 not in world.frames
    assert world.drive.axis.velocity == pytest.approx(50.0, rel=1e-3)
    assert world.drive.axis.position == pytest.approx(50.0 * 1.0, abs=1.0)
    beats = world.frames.count(0x701)
    assert 9 <= beats <= 11  # 0x1017 = 100 ms, on the emulator's clock


def test_syncs_only_latch(world: World) -> None:
    """The same second with a SYNC every 2 ms, or every 50 ms: the same motion at the end."""
    world.enable(-1)  # voltage
    world.node.sdo[0x2100].raw = 5000  # mV
    world.wait(0.5, sync_every=0.002)
    fast = world.drive.axis.position
    other = World()
    try:
        other.enable(-1)
        other.node.sdo[0x2100].raw = 5000
        other.wait(0.5, sync_every=0.05)
        assert other.drive.axis.position == pytest.approx(fast, rel=1e-12)
    finally:
        other.close()
    world.host.send_message(0x80, b"")  # a SYNC latches the state of the clock's last period
    latched = world.node.sdo[0x6064].raw
    assert latched == math.floor(world.drive.axis.position * CPR / (2 * math.pi))


def test_a_load_profile_runs_from_operation_enabled() -> None:
    """The clock reads 1000 s when the drive is enabled; the load's step at 1.5 s comes 1.5 s
    after the enable, not at clock time 1.5 s (which is long past), nor 1.5 s after the
    emulator started (onto the disabled motor: it spun up to over-speed before any run)."""
    w = World(start=1000.0, load="step:0.02:1.5")
    try:
        w.wait(2.0)
        assert w.drive.axis.velocity == 0.0  # disabled, and the load's time has not started
        w.enable(-1)  # 0 V: nothing moves the motor but the load
        w.wait(1.4)
        assert abs(w.drive.axis.velocity) < 1e-6
        w.wait(0.2)
        assert w.drive.axis.velocity < -1.0  # the load (against positive speed) spins it back
    finally:
        w.close()


def test_the_sdo_answer_takes_the_profile_s_response_time() -> None:
    """The epos4 twin answers an SDO request 0.5 ms (its profile) after it came, on its clock."""
    from plant_emulator.device_profile import load_profile, zoo
    from plant_emulator.presets import build_twin

    t = [0.0]
    hub = SyncHub()
    host, dev = canopen.Network(), canopen.Network()
    attach_network(host, hub.bus(queue=False, channel="host"))
    attach_network(dev, hub.bus(queue=False, channel="device"))
    frames: list[int] = []
    hub.taps.append(lambda m: frames.append(m.arbitration_id))
    try:
        profile = load_profile(zoo()["epos4"])
        assert profile.timing.sdo_response == 0.0005
        devices, _ = build_twin(profile, dev)
        devices[0].boot()
        clock = WorldClock(devices, lambda: t[0])
        host.send_message(0x601, bytes([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]))  # upload 0x1000
        t[0] = 0.0004
        clock.advance()
        assert 0x581 not in frames
        t[0] = 0.0006
        clock.advance()
        assert 0x581 in frames
    finally:
        for net in (host, dev):
            net.bus.shutdown()


def test_a_sync_locks_the_drives_periods_to_itself(world: World) -> None:
    """A CiA 402 drive synchronises its cycle to SYNC: the first SYNC (after half a second without
    one), 0.3 periods after the emulator's latest period boundary, moves that boundary to itself;
    the next, 0.7 periods after it, ends the period there (the boundary nearest it) and moves the
    phase by a sixteenth of its offset (a phase-locked loop: ``Shaft._lock``); the TPDO samples
    the shaft at the boundary, and the next period ends a period after it."""
    world.enable(9)  # CSV
    world.host.send_message(0x000, bytes([0x01, 2]))  # NMT start the encoder (node 2)
    world.node.sdo[0x60FF].raw = round(50.0 * CPR / (2 * math.pi))
    world.wait(0.5)
    shaft = world.drive.shaft
    tpdos: dict[int, bytes] = {}
    world.hub.taps.append(lambda m: tpdos.__setitem__(m.arbitration_id, bytes(m.data)))
    for fraction, periods, moved_by in ((0.3, 0, 1.0), (0.7, 1, 1 / 16)):
        before, position = shaft.t, shaft.position
        sync = world.time = world.hub.clock = before + fraction * world.period
        world.host.send_message(0x80, b"")
        boundary = before + periods * world.period
        assert shaft.t == pytest.approx(boundary + moved_by * (sync - boundary), abs=1e-12)
        assert shaft.sync_offset == 0.0
        moved = shaft.position - position
        assert moved == pytest.approx(50.0 * periods * world.period, rel=0.05, abs=1e-9)
        expected = math.floor(shaft.position * CPR / (2 * math.pi))
        assert world.node.sdo[0x6064].raw == expected
        assert tpdos[0x282][:4] == expected.to_bytes(4, "little")  # the encoder's TPDO2: 0x6004 first
    end = shaft.t
    world.time = end + 0.99 * world.period
    world.clock.advance()
    assert shaft.t == end  # the next period ends a period after the boundary
    world.time = end + world.period
    world.clock.advance()
    assert shaft.t == pytest.approx(end + world.period)


def test_an_emulator_that_did_not_run_does_not_catch_up(world: World) -> None:
    """A second in which the emulator's loop did not run (a stalled machine): its world stands
    still over it, but for the clock's allowance of 10 ms: one advance simulates 10 ms, not a
    second, no timer fires for the stall (the heartbeat, 100 ms, is not due), and the second is
    counted; then time goes on as before."""
    world.enable(9)  # CSV
    world.node.sdo[0x60FF].raw = round(50.0 * CPR / (2 * math.pi))
    world.wait(0.2)
    shaft = world.drive.shaft
    start, t = shaft.position, shaft.t
    world.frames.clear()
    world.time += 1.0
    world.clock.advance()
    assert world.clock.stalled == pytest.approx(1.0 - 0.01)
    assert shaft.t == pytest.approx(t + 0.01) and world.clock.skipped == 0
    assert shaft.position - start == pytest.approx(50.0 * 0.01, rel=0.05)  # 10 ms of motion, not 1 s
    assert 0x701 not in world.frames
    world.wait(0.1)
    assert world.frames.count(0x701) == 1  # its heartbeat, 100 ms on
    assert shaft.position - start == pytest.approx(50.0 * 0.11, rel=0.05)


@pytest.mark.parametrize("loop", [0.002, 0.009, 0.05], ids=["loop-2ms", "loop-9ms", "stalled-50ms"])
def test_a_lost_host_is_noticed_within_a_period_of_its_deadline_however_late_the_loop_runs(
    loop: float,
) -> None:
    """The host (SYNC every 1 ms, RPDO1 with 4.4 V 0.6 ms after it) dies at about 185 rad/s;
    the emulator's own loop then runs every ``loop`` [s] (2 ms: ``rig emulate``'s tick; 9 ms: a
    loaded machine, under the clock's 10 ms allowance; 50 ms: stalled past it). The drive finds
    the RPDO deadline (20 ms, 0x1400:05) run out within one period (0.4 ms) of it on its own
    clock, counted from the instant the last RPDO came, and its quick stop (0x6007 = 3, 0x605A =
    2) brakes along 0x6085 from there: the travel from the last RPDO is what the deadline and
    the ramp need from that speed (issue 33: within 10 %; here 2 %). Before, the deadline was
    checked at the loop's ticks only (found up to a tick late, the voltage held meanwhile) from
    the tick before the RPDO came (up to a tick early)."""
    w = World()
    try:
        w.enable(-1)  # voltage
        w.node.sdo[0x6007].raw = 3  # quick stop on a lost host
        w.node.sdo[0x1400][5].raw = 20  # [ms] the deadline on RPDO1 (controlword, 0x2100 [mV])
        noticed: list[tuple[float, float, float]] = []  # (device time [s], rad, rad/s) at EMCY 0x8250
        drive, shaft = w.drive, w.drive.shaft

        def emcy(can_id: int, data: bytearray, timestamp: float) -> None:
            if data[:2] == b"\x50\x82":
                noticed.append((shaft.t, drive.axis.position, drive.axis.velocity))

        w.host.subscribe(0x81, emcy)
        rpdo = (0x0F).to_bytes(2, "little") + (4400).to_bytes(4, "little")
        for _ in range(600):  # 0.6 s of the host's cycles
            w.time = w.hub.clock = w.time + 0.4e-3
            w.host.send_message(0x80, b"")
            w.time = w.hub.clock = w.time + 0.6e-3
            w.host.send_message(0x201, rpdo)
        last, speed = w.time, drive.axis.velocity  # (no stall yet: the device's time is the loop's)
        start = drive.axis.position + speed * (last - shaft.t)  # where the shaft was at the RPDO
        assert speed > 180.0
        while shaft.t < last + 0.5:  # the host is gone: only the emulator's loop runs
            w.time += loop
            w.clock.advance()
        assert len(noticed) == 1, noticed
        t_notice, at, w_notice = noticed[0]  # (a stall is no time of the drive's: not counted)
        assert last + 0.020 < t_notice <= last + 0.020 + w.period + 1e-9
        assert drive.sm.state.name == "SWITCH_ON_DISABLED" and drive.axis.velocity == 0.0
        decel = drive.read(0x6085) / drive.counts_per_rad  # [rad/s^2]
        need = speed * 0.020 + speed * speed / (2.0 * decel)
        travel = drive.axis.position - start
        assert travel == pytest.approx(need, rel=0.02)
        assert drive.axis.position - at == pytest.approx(w_notice * w_notice / (2.0 * decel), rel=0.02)
    finally:
        w.close()


def test_a_loop_too_slow_for_its_periods_still_sleeps(world: World) -> None:
    """A machine on which preparing a period takes longer than the period (an emulated CPU, 10-25
    times slower): the preparation is due again as soon as it is done, yet the loop sleeps a lead,
    or its receive path (the SDO answers) would get no CPU beside a real-time loop; on time, it
    sleeps up to the next preparation, at most the tick."""
    clock = world.clock
    lead = clock.lead()
    assert lead == pytest.approx(0.5 * world.period)
    clock.prepare()
    on_time = clock.pause(0.002)
    assert 0.0 < on_time <= min(0.002, world.period)
    world.time += 3.0 * world.period  # the preparation took three periods
    assert clock.pause(0.002) == pytest.approx(lead)
    assert clock.pause(0.5 * lead) == pytest.approx(0.5 * lead)


def test_the_steps_a_period_needs_are_computed_before_time_starts(monkeypatch: pytest.MonkeyPatch) -> None:
    """The first stop of the shaft within a period takes the step again in parts down to 0.1 us
    (``DcServoAxis._step``), each part length a matrix exponential; the real-time clock has them
    computed before its time starts, so no SYNC's preparation computes one under the devices'
    lock (five of them took 40-60 ms there: 100 late cycles in a row, a false stop)."""
    from plant_emulator import axes

    built: list[float] = []
    real = axes.LinearZOH

    def counted(A: object, B: object, dt: float) -> object:
        built.append(dt)
        return real(A, B, dt)

    monkeypatch.setattr(axes, "LinearZOH", counted)
    world = World()
    try:
        axis = world.drive.axis
        assert isinstance(axis, axes.DcServoAxis) and axis.coulomb > 0.0
        warmed = len(built)
        assert warmed >= 2
        quarter = world.period / max(1, math.ceil(world.period / axis.inner_dt - 1e-9))
        for h in (world.period, quarter):
            slow = 0.5 * axis.coulomb / axis.motor.j * h  # the friction stops it within h
            axis.x = [0.0, slow, 0.0]
            axis._step(0.0, 0.0, h)
            assert axis.x[1] == 0.0  # it stopped (and the step was refined)
        assert len(built) == warmed  # nothing computed in the period
    finally:
        world.close()
