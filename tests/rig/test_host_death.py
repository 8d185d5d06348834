"""A host that dies mid-run leaves a drive that stops itself, across real processes and sockets.

Two cases: a zoo twin's heartbeat consumer (CSV), and the toolkit's own drive in voltage mode,
whose deadline on its command RPDO stops it within a few periods.

``rig emulate --device epos4`` (the twin, real time on its own clock) and ``rig run`` (real
time, CSV at 50 rad/s over socketcand) are separate processes; the run is killed with SIGKILL
(no safe stop, no Python cleanup). The drive, configured by the run's set-up (heartbeat
consumer 0x1016 on the host's heartbeat, 0x6007 = quick stop), must notice the silence (EMCY
0x8130) and brake along its own ramp to rest. This test's own client only listens until the
host is dead (two SDO clients on one server would mix their transfers), then reads by SDO.
"""

from __future__ import annotations

import contextlib
import functools
import io
import math
import os
import pathlib
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable

import canopen
import pytest

from drivers.bus import open_bus
from drivers.maps import CIA402_EDS
from plant_emulator.device_profile import load_profile, zoo
from rig.emulator.spawn import spawn_emulator, stop_rig
from rig.faults.wire import CONFIG, PERIOD
from rig.faults.wire_probe import wait_for

pytestmark = pytest.mark.timing  #: real time across processes: wall-clock bound


def run_config(out: pathlib.Path, port: int, eds: pathlib.Path) -> str:
    """``rig run``'s configuration: the cross-process fault scenarios' (CSV at 50 rad/s, 2 ms),
    with a 1 s watchdog: these tests are about what a stop does, and a loaded machine (the CI
    ran at a load of 5.7 on 2 cores) delays a TPDO past the default 0.1 s."""
    text = CONFIG.format(duration=60.0, period=PERIOD, out=out, port=port, eds=eds, speed=50.0)
    return text.replace("speed = 250.0\n", "speed = 250.0\nwatchdog = 1.0\n")


class KilledHost:
    """``rig emulate ARGS`` and ``rig run`` of ``config(port)`` (real time, socketcand), with this
    test's own client recording the drive's frames (receive time, COB-ID, data); ``kill``
    SIGKILLs the run once it has sent that many TPDO1s; ``close`` ends the rest."""

    def __init__(
        self, tmp_path: pathlib.Path, emulate: tuple[str, ...], config: Callable[[int], str]
    ) -> None:
        self.tmp_path = tmp_path
        self.emulator, port = spawn_emulator(*emulate)
        self.host: subprocess.Popen[bytes] | None = None
        self.stack = contextlib.ExitStack()
        self.frames: list[tuple[float, int, bytes]] = []
        self._lock = threading.Lock()
        bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)  # frames behind < ok > kept
        self.network = canopen.Network(bus)
        self.network.connect()
        for cob in (0x81, 0x181, 0x281, 0x381, 0x481):
            self.network.subscribe(cob, self._seen)
        path = tmp_path / "run.toml"
        path.write_text(config(port))
        host_err = self.stack.enter_context((tmp_path / "host.err").open("w"))
        self.host = subprocess.Popen(
            [sys.executable, "-m", "rig.cli", "run", "--config", str(path)],
            stdout=subprocess.DEVNULL,
            stderr=host_err,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )

    def _seen(self, cob: int, data: bytearray, ts: float) -> None:
        with self._lock:
            self.frames.append((time.monotonic(), cob, bytes(data)))

    def kill(self, cycles: int) -> float:
        """SIGKILL the run after ``cycles`` TPDO1s; the kill's time (monotonic)."""
        host = self.host
        assert host is not None

        def turning() -> bool:
            with self._lock:
                n = sum(1 for _, c, _ in self.frames if c == 0x181)
            return n > cycles or host.poll() is not None

        wait_for(turning, 60.0, "the run's TPDOs")
        assert host.poll() is None, (self.tmp_path / "host.err").read_text()[-3000:]
        killed = time.monotonic()
        host.send_signal(signal.SIGKILL)
        host.wait(timeout=10)
        return killed

    def emcy(self, code: int) -> None:
        """Wait for the drive's EMCY ``code``."""
        data = code.to_bytes(2, "little")
        frames = self.frames
        try:
            wait_for(lambda: any(c == 0x81 and d[:2] == data for _, c, d in frames), 5.0, f"EMCY {code:#06x}")
        except TimeoutError as exc:
            seen = [d[:2][::-1].hex() for _, c, d in frames if c == 0x81]
            raise TimeoutError(f"{exc}; the drive's EMCYs: {seen}; {len(frames)} frames") from None

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.network.disconnect()
        if self.host is not None and self.host.poll() is None:
            self.host.kill()
            self.host.wait(timeout=10)
        self.stack.close()
        _out, err = stop_rig(self.emulator, timeout=10)
        (self.tmp_path / "emulator.err").write_text(err)  # its log, kept for a failure's reading
        assert self.emulator.returncode == 0, err


def test_a_killed_host_leaves_a_drive_that_stops_itself(tmp_path: pathlib.Path) -> None:
    eds = load_profile(zoo()["epos4"]).eds
    world = KilledHost(tmp_path, ("--device", "epos4"), lambda port: run_config(tmp_path, port, eds))
    try:
        world.kill(100)
        world.emcy(0x8130)
        source = io.StringIO(eds.read_text())
        source.name = eds.name
        node = canopen.RemoteNode(1, canopen.import_od(source, 1))
        world.network.add_node(node)
        # the quick stop ramp ends in SWITCH ON DISABLED (0x605A = 2), the motor at rest
        wait_for(lambda: node.sdo[0x6041].raw & 0x4F == 0x40, 5.0, "SWITCH ON DISABLED")
        assert abs(node.sdo[0x606C].raw) <= 1  # rpm
    finally:
        world.close()


def voltage_config(out: pathlib.Path, port: int, deadline: float, volts: float = 3.0) -> str:
    """``run_config``'s on the toolkit's drive in voltage mode: ``volts`` [V] held (``replay``), 1 ms
    cycles, the drive's deadline on the commands 5 periods, in real time at least ``deadline`` [s]."""
    text = CONFIG.format(duration=60.0, period=0.001, out=out, port=port, eds=CIA402_EDS, speed=0.0)
    axis = f'mode = "voltage"\nrpdo_deadline_periods = 5\nrpdo_deadline = {deadline}'
    text = text.replace('mode = "csv"', axis)
    text = text.replace('kind = "speed-reference"', f'kind = "replay"\nu = [{volts}]')
    return text.replace("speed = 250.0\n", "speed = 250.0\nwatchdog = 1.0\n")


VOLTS = 4.4  #: [V] held: the preset's (3.5) turns at u b_m / a_m = 187 rad/s, issue 33's speed


@pytest.mark.parametrize("run", range(10))
def test_a_killed_host_in_voltage_mode_leaves_the_shaft_where_the_deadline_and_the_ramp_take_it(
    tmp_path: pathlib.Path, run: int
) -> None:
    """``rig emulate --preset dc-servo`` (the toolkit's drive, real time) and ``rig run`` in
    voltage mode (4.4 V held, 1 ms cycles) in processes of their own over socketcand; the run is
    SIGKILLed at about 187 rad/s. The drive's deadline on its command RPDO (real time: 20 ms, the
    default floor over 5 periods) starts its quick stop (0x6007 = 3, 0x605A = 2), found within a
    period of it on the drive's own clock: the shaft travels, from the last sample before the
    kill, what the deadline at the speed it had and then 0x6085's ramp from that speed need,
    within 10 % (issue 33 item 5), in each of 10 runs (each a pair of processes of its own).
    Measured on the wire: this test's own client's TPDOs before the kill (decoded with the
    drive's mapping read by SDO after it) and the position by SDO once the drive is at rest, not
    the run's samples on disk, which a SIGKILL leaves up to the recorder's flush period (50 ms)
    short of the kill. Before the deadline was checked each period, the issue measured 112 rad
    with the heartbeat's 0.3 s and the voltage held."""
    deadline = 0.02
    config = functools.partial(voltage_config, tmp_path, deadline=deadline, volts=VOLTS)
    world = KilledHost(tmp_path, ("--preset", "dc-servo"), config)
    try:
        world.kill(700)  # 0.7 s of 4.4 V: 11 time constants (1/a_m), at its steady speed
        world.emcy(0x8250)
        node = canopen.RemoteNode(1, CIA402_EDS)
        world.network.add_node(node)
        wait_for(lambda: node.sdo[0x6041].raw & 0x4F == 0x40, 10.0, "SWITCH ON DISABLED")
        wait_for(lambda: node.sdo[0x606C].raw == 0, 10.0, "the shaft at rest")
        final = node.sdo[0x6064].raw
        timer_ms = node.sdo[0x1400][5].raw  # the deadline the set-up wrote, never lifted
        per_rad = node.sdo[0x608F][1].raw / node.sdo[0x608F][2].raw / (2 * math.pi)
        decel = node.sdo[0x6085].raw / per_rad  # [rad/s^2]
        node.tpdo.read(from_od=False)
        maps = {m.cob_id: m for m in node.tpdo.map.values() if m.enabled}
    finally:
        world.close()

    def values(index: int) -> list[tuple[float, float]]:
        """(receive time, value in SI) of every TPDO carrying ``index``."""
        out = []
        for t, cob, data in world.frames:
            m = maps.get(cob)
            var = next((v for v in m.map if v.index == index), None) if m is not None else None
            if var is not None:
                m.data = bytearray(data)
                out.append((t, var.raw / per_rad))
        return out

    # the drive's last TPDO answered the host's last SYNC (none without it): the state at the kill,
    # up to a cycle before it; this client's receive times are no guide on a loaded machine (its
    # thread ran up to 0.2 s behind here: a "last TPDO before the kill" that old is 37 rad back)
    start, w_kill = values(0x6064)[-1][1], values(0x606C)[-1][1]
    travel = final / per_rad - start
    ramp = w_kill * w_kill / (2.0 * decel)
    need = w_kill * timer_ms / 1000.0 + ramp
    print(
        f"run {run}: killed at {w_kill:.1f} rad/s; deadline {timer_ms} ms, 0x6085 {decel:.0f} rad/s^2; "
        f"travel {travel:.2f} rad, the deadline and the ramp need {need:.2f} ({travel / need:.3f})"
    )
    assert timer_ms == round(deadline * 1000) and w_kill > 180.0
    assert travel == pytest.approx(need, rel=0.10)
