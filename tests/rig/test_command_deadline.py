"""The toolkit's drive stops itself when the host's commands stop, in its voltage and dq modes.

The host's set-up (``drivers.cia402``) gives the command RPDO of the toolkit's own drive a
deadline, its event timer (CiA 301 0x1400+n sub 5) at ``rpdo_deadline_periods`` periods (in
lock-step; real time adds a floor in seconds, ``rpdo_deadline``); the emulated
drive (``plant_emulator.supervision``, the same watch as every RPDO's) reports the silence
(EMCY 0x8250) and reacts as 0x6007 says (the host sets quick stop): its ramp to rest. A stop
the host makes on purpose feeds the deadline through the ramp and lifts it once the disable is
confirmed (``tests/rig/test_stop_order.py``). Lock-step on the in-process bus; the host's
death is its cycle ending while SYNC goes on (as a SYNC producer of its own would keep it).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from drivers.cia402 import Cia402Axis
from drivers.maps.cia import PowerState
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.lockstep import LockstepBench

DEADLINE = 5  #: periods


class Rig:
    """``preset`` on the in-process bus, the host's driver of its drive set up and enabled."""

    def __init__(self, preset: str, mode: str, deadline: int) -> None:
        self.bench = LockstepBench(preset)
        self.frames: list[tuple[int, bytes]] = []
        self.bench.host.bus.listeners.append(lambda m: self.frames.append((m.arbitration_id, bytes(m.data))))
        drive = self.bench.devices[0]
        assert isinstance(drive, EmulatedDrive)
        self.drive = drive
        self.period = self.bench.period
        self.axis = Cia402Axis(
            "motor",
            self.bench.host,
            1,
            mode=mode,
            period=self.period,
            rpdo_deadline=deadline * self.period,
            abort_connection=3,  # quick stop, rig run's default
        )
        self.axis.idle = self.bench.sync
        self.axis.setup()
        self.axis.enable()

    def cycles(self, n: int, command: float | complex | None) -> list[float]:
        """``n`` SYNCs, with ``command`` sent after each (None: nothing: the host is gone)."""
        speeds = []
        for _ in range(n):
            self.bench.sync()
            speeds.append(self.drive.axis.velocity)
            if command is not None:
                self.axis.command(command)
        return speeds

    def emcy(self) -> list[int]:
        return [int.from_bytes(d[:2], "little") for cob, d in self.frames if cob == 0x81 and d[:2] != b"\0\0"]

    def close(self) -> None:
        self.axis.close()
        self.bench.close()


@pytest.fixture
def servo() -> Iterator[Rig]:
    rig = Rig("dc-servo", "voltage", DEADLINE)
    yield rig
    rig.close()


def test_set_up_gives_the_command_rpdo_a_deadline_of_a_few_periods(servo: Rig) -> None:
    """5 periods of 0.4 ms, rounded up to whole ms: 2 ms in RPDO1's event timer."""
    assert servo.drive.read(0x1400, 5) == 2
    assert servo.drive.rpdo_deadlines.times == {0: 0.002}


def test_a_host_that_stops_sending_has_the_drive_stop_itself_within_the_deadline(servo: Rig) -> None:
    """A voltage command held by a drive without a deadline accelerates the motor for as long
    as nothing else stops it (the heartbeat's 0.3 s: -112 rad in the issue's run); with one the
    drive's quick stop starts within the deadline, and the shaft moves no further than the
    speed it had for that time plus its ramp to rest at 0x6085."""
    speeds = servo.cycles(round(0.3 / servo.period), 6.0)
    w = speeds[-1]
    assert w > 100.0
    start = servo.drive.axis.position
    speeds = servo.cycles(DEADLINE + 2, None)  # the host is gone: SYNC goes on, no RPDO
    assert 0x8250 in servo.emcy()
    assert servo.drive.sm.state is PowerState.QUICK_STOP_ACTIVE
    w_trip = max(speeds)
    speeds = servo.cycles(round(0.5 / servo.period), None)
    assert set(speeds[-100:]) == {0.0} and servo.drive.sm.state is PowerState.SWITCH_ON_DISABLED
    decel = servo.drive.read(0x6085) / servo.drive.counts_per_rad  # [rad/s^2]
    ramp = w_trip * w_trip / (2.0 * decel)
    travel = servo.drive.axis.position - start
    assert ramp < travel <= w_trip * (DEADLINE + 2) * servo.period + ramp * 1.05


def test_without_a_deadline_the_held_voltage_drives_on() -> None:
    """The test above fails without the deadline: 100 periods of silence later the drive
    still holds the voltage and the motor runs on."""
    rig = Rig("dc-servo", "voltage", 0)
    try:
        assert rig.drive.read(0x1400, 5) == 0
        rig.cycles(round(0.3 / rig.period), 6.0)
        speeds = rig.cycles(100, None)
        assert rig.drive.sm.state is PowerState.OPERATION_ENABLED and 0x8250 not in rig.emcy()
        assert speeds[-1] > speeds[0] > 100.0
    finally:
        rig.close()


def test_a_stop_on_purpose_feeds_the_deadline_and_lifts_it_only_after_the_disable(servo: Rig) -> None:
    """Quick stop by the host: the event timer stays while the drive brakes, fed by the stop's
    RPDOs (``keep_stopping``: the quick stop and 0 V), so the ramp reports no timeout; the
    disable, confirmed by the statusword, lifts it; the next enable sets it again. Before, the
    quick stop lifted it first, while the drive was still enabled."""
    servo.cycles(100, 3.0)
    servo.axis.quick_stop()
    assert servo.drive.read(0x1400, 5) == 2
    for _ in range(round(0.2 / servo.period)):
        servo.axis.keep_stopping()
        servo.bench.sync()
    assert servo.drive.sm.state is PowerState.SWITCH_ON_DISABLED  # its ramp ended (0x605A = 2)
    assert servo.drive.read(0x1400, 5) == 2
    servo.axis.disable()
    assert servo.drive.read(0x1400, 5) == 0
    servo.cycles(20, None)
    assert 0x8250 not in servo.emcy()
    servo.axis.enable()
    assert servo.drive.read(0x1400, 5) == 2


def test_the_dq_drive_stops_itself_and_its_current_ends() -> None:
    """Mode -2 (the grid converter): the deadline is set up there too (4 ms: 5 periods of
    0.74 ms, rounded up) and fires when the RPDOs stop. Here the converter's own over-current
    trip (EMCY 0x2310) comes first: its modulator holds the last alpha-beta voltage while the
    grid's turns on, 0.23 rad a period. Either stop opens the bridge (no speed loop to brake
    with): no current flows after it (the DC link above the grid's line-to-line peak blocks the
    diodes), where zero volts would short the grid through L1."""
    rig = Rig("grid-converter", "dq-voltage", DEADLINE)
    try:
        assert rig.drive.read(0x1400, 5) == 4
        source = rig.drive.axis.source  # type: ignore[attr-defined]
        rig.cycles(200, source + 20j)  # the source's voltage back, and 20 V of q
        assert rig.drive.axis.current > 1.0
        rig.cycles(DEADLINE + 2, None)
        assert 0x8250 in rig.emcy()
        assert rig.drive.sm.state in (PowerState.FAULT, PowerState.SWITCH_ON_DISABLED)
        currents = [rig.drive.axis.current for _ in range(10) if rig.cycles(1, None) is not None]
        assert set(currents) == {0.0}
    finally:
        rig.close()
