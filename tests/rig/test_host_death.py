"""A host that dies mid-run leaves a drive that stops itself, across real processes and sockets.

``rig emulate --device epos4`` (the twin, real time on its own clock) and ``rig run`` (real
time, CSV at 50 rad/s over socketcand) are separate processes; the run is killed with SIGKILL
(no safe stop, no Python cleanup). The drive, configured by the run's set-up (heartbeat
consumer 0x1016 on the host's heartbeat, 0x6007 = quick stop), must notice the silence (EMCY
0x8130) and brake along its own ramp to rest. This test's own client only listens until the
host is dead (two SDO clients on one server would mix their transfers), then reads by SDO.
"""

from __future__ import annotations

import contextlib
import io
import os
import pathlib
import signal
import subprocess
import sys
import threading

import can
import canopen
import pytest

from plant_emulator.device_profile import load_profile, zoo
from rig.fault_wire import CONFIG, PERIOD
from rig.process import spawn_emulator, stop_rig
from rig.wire_probe import wait_for

pytestmark = pytest.mark.timing  #: real time across processes: wall-clock bound


def run_config(out: pathlib.Path, port: int, eds: pathlib.Path) -> str:
    """``rig run``'s configuration: the cross-process fault scenarios' (CSV at 50 rad/s, 2 ms),
    with a 1 s watchdog: these tests are about what a stop does, and a loaded machine (the CI
    ran at a load of 5.7 on 2 cores) delays a TPDO past the default 0.1 s."""
    text = CONFIG.format(duration=60.0, period=PERIOD, out=out, port=port, eds=eds, speed=50.0)
    return text.replace("speed = 250.0\n", "speed = 250.0\nwatchdog = 1.0\n")


def test_a_killed_host_leaves_a_drive_that_stops_itself(tmp_path: pathlib.Path) -> None:
    eds = load_profile(zoo()["epos4"]).eds
    emulator, port = spawn_emulator("--device", "epos4")
    host: subprocess.Popen[bytes] | None = None
    stack = contextlib.ExitStack()
    try:
        bus = can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="can0", ignore_config=True)
        network = canopen.Network(bus)
        network.connect()
        frames: list[tuple[int, bytes]] = []
        lock = threading.Lock()

        def seen(cob: int, data: bytearray, ts: float) -> None:
            with lock:
                frames.append((cob, bytes(data)))

        for cob in (0x81, 0x181, 0x281, 0x381, 0x481):
            network.subscribe(cob, seen)
        config = tmp_path / "run.toml"
        config.write_text(run_config(tmp_path, port, eds))
        host_err = stack.enter_context((tmp_path / "host.err").open("w"))
        host = subprocess.Popen(
            [sys.executable, "-m", "rig.cli", "run", "--config", str(config)],
            stdout=subprocess.DEVNULL,
            stderr=host_err,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        running = host

        def turning() -> bool:
            return sum(1 for c, _ in frames if c in (0x181, 0x281)) > 200 or running.poll() is not None

        wait_for(turning, 60.0, "the run's TPDOs")
        assert host.poll() is None, (tmp_path / "host.err").read_text()[-3000:]
        host.send_signal(signal.SIGKILL)
        host.wait(timeout=10)
        wait_for(lambda: any(c == 0x81 and d[:2] == b"\x30\x81" for c, d in frames), 5.0, "EMCY 0x8130")
        source = io.StringIO(eds.read_text())
        source.name = eds.name
        node = canopen.RemoteNode(1, canopen.import_od(source, 1))
        network.add_node(node)
        # the quick stop ramp ends in SWITCH ON DISABLED (0x605A = 2), the motor at rest
        wait_for(lambda: node.sdo[0x6041].raw & 0x4F == 0x40, 5.0, "SWITCH ON DISABLED")
        assert abs(node.sdo[0x606C].raw) <= 1  # rpm
        network.disconnect()
    finally:
        if host is not None and host.poll() is None:
            host.kill()
            host.wait(timeout=10)
        stack.close()
        _out, err = stop_rig(emulator, timeout=10)
    assert emulator.returncode == 0, err
