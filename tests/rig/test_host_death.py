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
import re
import signal
import subprocess
import sys
import threading
import time

import can
import canopen
import pytest

from plant_emulator.device_profile import load_profile, zoo
from rig.process import spawn_rig, stop_rig

CONFIG = """
[run]
duration = 60.0
time = "realtime"
period = 0.002
output = "{out}"
name = "killed"

[bus]
interface = "socketcand"
channel = "can0"
host = "127.0.0.1"
port = {port}
heartbeat = 0.05

[[axis]]
name = "motor"
kind = "cia402"
node_id = 1
mode = "csv"
eds = "{eds}"
enable_timeout = 2.0
abort_connection = "quick-stop"

[axis.limits]
command = 200.0
speed = 250.0
watchdog_periods = 100

[controller]
kind = "speed-reference"
reads = ["motor"]
commands = ["motor"]

[reference]
kind = "constant"
value = 50.0
"""


def _wait(predicate, timeout: float, what: str) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.01)


def test_a_killed_host_leaves_a_drive_that_stops_itself(tmp_path: pathlib.Path) -> None:
    eds = load_profile(zoo()["epos4"]).eds
    emulator, line = spawn_rig("emulate", "--device", "epos4", "--socketcand-port", "0", stderr=True)
    host: subprocess.Popen[bytes] | None = None
    stack = contextlib.ExitStack()
    try:
        match = re.search(r"socketcand://127\.0\.0\.1:(\d+)", line)
        assert match, line
        port = int(match.group(1))
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
        config.write_text(CONFIG.format(out=tmp_path, port=port, eds=eds))
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

        _wait(turning, 60.0, "the run's TPDOs")
        assert host.poll() is None, (tmp_path / "host.err").read_text()[-3000:]
        host.send_signal(signal.SIGKILL)
        host.wait(timeout=10)
        _wait(lambda: any(c == 0x81 and d[:2] == b"\x30\x81" for c, d in frames), 5.0, "EMCY 0x8130")
        source = io.StringIO(eds.read_text())
        source.name = eds.name
        node = canopen.RemoteNode(1, canopen.import_od(source, 1))
        network.add_node(node)
        # the quick stop ramp ends in SWITCH ON DISABLED (0x605A = 2), the motor at rest
        _wait(lambda: node.sdo[0x6041].raw & 0x4F == 0x40, 5.0, "SWITCH ON DISABLED")
        assert abs(node.sdo[0x606C].raw) <= 1  # rpm
        network.disconnect()
    finally:
        if host is not None and host.poll() is None:
            host.kill()
            host.wait(timeout=10)
        stack.close()
        _out, err = stop_rig(emulator, timeout=10)
    assert emulator.returncode == 0, err
