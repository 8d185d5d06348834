"""The emulated drive stops along the ramp it declares, in every mode, voltage included.

A quick stop (controlword, 0x605A), a fault (0x605E) and a lost host (the heartbeat consumer
0x1016 running out, 0x6007 = 3: quick stop) at about 187 rad/s, the speed of issue 33's
SIGKILL, in each mode of the toolkit's drive (voltage, CST, CSV, PV, CSP): from the instant
the drive leaves OPERATION ENABLED the speed falls at the rate the option selects (0x6085 for
2, 0x6084 for 1, the current limit 0x6073 for 3: it brakes with all the torque it has), the
shaft travels what that ramp needs from the speed it had, w T + w^2 / (2 a) (its cycle acts at
the next SYNC, T later), and the drive ends at rest where the option says. Lock-step on the
in-process bus, with canopen's RemoteNode as the peer.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator

import canopen
import pytest

from drivers.maps import CIA402_EDS
from drivers.maps.cia import PowerState as S
from plant_emulator.axes import DcServoAxis
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.lockstep import LockstepBench

W0 = 187.0  #: [rad/s] the speed the stop comes at
PER_RAD = 4096 / (2 * math.pi)  #: the dc-servo drive's increments per rad
HOST = 0x7F  #: the node id whose heartbeat the drive consumes


class Stopping:
    """The dc-servo drive enabled in a mode, turning at about W0, with the host's heartbeat."""

    def __init__(self, mode: str) -> None:
        self.bench = LockstepBench("dc-servo")
        self.period = self.bench.period
        self.node = canopen.RemoteNode(1, CIA402_EDS)
        self.bench.host.add_node(self.node)
        drive = self.bench.devices[0]
        assert isinstance(drive, EmulatedDrive) and isinstance(drive.axis, DcServoAxis)
        self.drive, self.axis = drive, drive.axis
        self.beating = True
        sdo = self.node.sdo
        self.node.nmt.state = "OPERATIONAL"
        sdo[0x1016][1].raw = HOST << 16 | 5  # the host's heartbeat within 5 ms
        sdo[0x6007].raw = 3  # a lost host: quick stop
        sdo[0x6060].raw = MODES[mode]
        self.sync()
        for cw in (0x06, 0x0F):
            sdo[0x6040].raw = cw
        SPIN[mode](self)
        assert self.axis.velocity == pytest.approx(W0, abs=4.0)

    def sync(self, n: int = 1) -> None:
        for _ in range(n):
            self.bench.sync()
            if self.beating:
                self.bench.host.send_message(0x700 + HOST, b"\x05")

    def seconds(self, t: float) -> int:
        return round(t / self.period)


def _voltage(s: Stopping) -> None:
    s.node.sdo[0x2100].raw = round(W0 * 16.0 / 680.0 * 1000.0)  # mV: u b_m / a_m of (3.5) is W0
    s.sync(s.seconds(0.4))


def _torque(s: Stopping) -> None:
    s.node.sdo[0x6071].raw = 100  # per mille of 0x6076
    while s.axis.velocity < W0:
        s.sync()
    s.node.sdo[0x6071].raw = 0


def _velocity(s: Stopping) -> None:
    s.node.sdo[0x60FF].raw = round(W0 * PER_RAD)
    s.sync(s.seconds(0.4))


def _position(s: Stopping) -> None:
    target = s.axis.position
    for k in range(s.seconds(0.4)):
        target += W0 * min(1.0, k * s.period / 0.1) * s.period
        s.node.sdo[0x607A].raw = round(target * PER_RAD)
        s.sync()


MODES = {"voltage": -1, "cst": 10, "csv": 9, "pv": 3, "csp": 8}
SPIN: dict[str, Callable[[Stopping], None]] = {
    "voltage": _voltage,
    "cst": _torque,
    "csv": _velocity,
    "pv": _velocity,
    "csp": _position,
}


@pytest.fixture
def stopping(request: pytest.FixtureRequest) -> Iterator[Stopping]:
    s = Stopping(request.param)
    yield s
    s.bench.close()


def _stop(s: Stopping, how: str) -> tuple[float, float, list[float]]:
    """Stop ``how``; (speed [rad/s] and position [rad] when the drive left OPERATION ENABLED,
    the speeds of each period after), until the drive is at rest (1 s at most)."""
    if how == "quick-stop":
        s.node.sdo[0x6040].raw = 0x0B
    elif how == "fault":
        s.drive.raise_fault(0x8400)
    else:  # the host dies: its heartbeat stops
        s.beating = False
        for _ in range(s.seconds(0.1)):
            if s.drive.sm.state is not S.OPERATION_ENABLED:
                break
            s.sync()
    assert s.drive.sm.state is not S.OPERATION_ENABLED
    w0, x0, speeds = s.axis.velocity, s.axis.position, []
    for _ in range(s.seconds(1.0)):
        s.sync()
        speeds.append(s.axis.velocity)
        if abs(speeds[-1]) < 0.02 and s.drive.sm.state in (S.FAULT, S.SWITCH_ON_DISABLED):
            break
    return w0, x0, speeds


def _check_ramp(s: Stopping, how: str, rate: float, *, rel: float = 0.02) -> None:
    w0, x0, speeds = _stop(s, how)
    travel = s.axis.position - x0
    assert travel == pytest.approx(w0 * s.period + w0 * w0 / (2.0 * rate), rel=rel)
    half = (next(k for k, w in enumerate(speeds) if w < w0 / 2.0) + 1) * s.period
    assert half == pytest.approx(s.period + w0 / (2.0 * rate), abs=max(2e-3, rel * w0 / rate))
    assert s.drive.sm.state is (S.FAULT if how == "fault" else S.SWITCH_ON_DISABLED)
    assert abs(s.axis.velocity) < 0.02


STOPS = [
    (m, how)
    for m in MODES
    for how in ("quick-stop", "fault", "lost-host")
    if (m, how) != ("csp", "lost-host")
]


@pytest.mark.parametrize(("stopping", "how"), STOPS, indirect=["stopping"])
def test_every_stop_follows_0x6085_in_every_mode(stopping: Stopping, how: str) -> None:
    """0x605A = 0x605E = 2 (the toolkit drive's defaults): 0x6085's ramp, 1,534 rad/s^2 (its
    EDS's 1,000,000 increments/s^2); at 187 rad/s 11.4 rad and 61 ms to half speed."""
    decel = stopping.node.sdo[0x6085].raw / PER_RAD
    assert decel == pytest.approx(1534.0, abs=1.0)
    _check_ramp(stopping, how, decel)


@pytest.mark.parametrize("stopping", ["csp"], indirect=True)
def test_a_csp_drive_holds_the_last_target_until_it_finds_the_host_lost(stopping: Stopping) -> None:
    """CSP, the host gone: until its heartbeat consumer runs out (5 ms) the drive follows the
    last 0x607A it got (CiA 402's cyclic position: the target in force), its position loop
    braking the shaft toward it harder than any ramp; then the quick stop's ramp from the speed
    left. The shaft stops short of where 0x6085's ramp from 187 rad/s would have taken it."""
    x_death, w_death = stopping.axis.position, stopping.axis.velocity
    w0, _, _ = _stop(stopping, "lost-host")
    decel = stopping.node.sdo[0x6085].raw / PER_RAD
    assert w0 < w_death - 50.0  # braked before the loss was found
    assert stopping.axis.position - x_death < w_death * w_death / (2.0 * decel)
    assert stopping.drive.sm.state is S.SWITCH_ON_DISABLED and abs(stopping.axis.velocity) < 0.02


@pytest.mark.parametrize("how", ["quick-stop", "fault"])
@pytest.mark.parametrize("stopping", ["voltage"], indirect=True)
def test_option_1_follows_0x6084(stopping: Stopping, how: str) -> None:
    """Option 1 of 0x605A or 0x605E: the slow down ramp, 0x6084 (767 rad/s^2), twice as long."""
    stopping.node.sdo[0x605A if how == "quick-stop" else 0x605E].raw = 1
    _check_ramp(stopping, how, stopping.node.sdo[0x6084].raw / PER_RAD)


@pytest.mark.parametrize("how", ["quick-stop", "fault"])
@pytest.mark.parametrize("stopping", ["voltage"], indirect=True)
def test_option_3_brakes_at_the_current_limit(stopping: Stopping, how: str) -> None:
    """Option 3: the speed set-point to zero at once, the speed loop braking with all the current
    it has: 0x6073 of 0x6075, 30 A, never more (at each period's end), about 20,000 rad/s^2
    (k_t 30 A / J; the current's rise and the friction within 5 %)."""
    stopping.node.sdo[0x605A if how == "quick-stop" else 0x605E].raw = 3
    limit = stopping.axis.loops.max_torque / stopping.axis.motor.k_t  # [A]
    assert limit == pytest.approx(30.0)
    peak = [0.0]

    def current() -> None:
        peak[0] = max(peak[0], abs(stopping.axis.current))

    stopping.bench.hub.taps.append(lambda m: current())
    _check_ramp(stopping, how, stopping.axis.loops.max_torque / stopping.axis.motor.j, rel=0.05)
    assert 0.95 * limit < peak[0] <= limit * (1 + 1e-6)
