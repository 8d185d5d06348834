"""Under a connection flood, a real-time run's shaft stays in its window and its stop ends at rest.

Processes of their own on 127.0.0.1, as issue 33 measured: ``rig emulate --preset dc-servo``
(real time, socketcand), ``rig run`` of the section VII.B servo (examples/dc_servo_position.toml
in real time at 1 kHz: 10 rad in 1 s, position window -1..12 rad), and, from this process once
the run turns, 200 rawmode clients reading every frame and 2,000 connections one after another
(``rig.bench.socketcand_clients``' ``hold`` and ``churn``). This test's own client records the
drive's TPDOs and reads it by SDO once the run has ended. Issue 33 measured the drive running on
a stale command after a stop that lifted its deadline while it was enabled, -379 rad/s and
-83.6 rad; before the server wrote each client once a round, the host's frames waited 30-130 ms
in its socket and the shaft ended at 16.5 to 79.5 rad in five runs of five.
"""

from __future__ import annotations

import math
import pathlib
import threading
from typing import Any

import canopen
import pytest

from drivers.maps import CIA402_EDS
from rig.bench.socketcand_clients import churn, hold
from rig.faults.wire_probe import wait_for
from tests.rig.test_host_death import KilledHost

pytestmark = pytest.mark.timing  #: real time across processes: wall-clock bound

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
WINDOW = (-1.0, 12.0)  #: [rad] the example's [axis.limits] position_min, position_max


def run_config(out: pathlib.Path, port: int) -> str:
    """The example in real time at 1 kHz against the emulator on ``port``."""
    text = EXAMPLE.read_text()
    for old, new in (
        ('time = "lockstep"', 'time = "realtime"\nperiod = 0.001'),
        ('output = "runs"', f'output = "{out}"'),
        ("port = 29536", f"port = {port}"),
    ):
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def test_a_run_under_a_connection_flood_keeps_its_shaft_in_the_window_and_ends_at_rest(
    tmp_path: pathlib.Path,
) -> None:
    ports: list[int] = []

    def config(port: int) -> str:
        ports.append(port)
        return run_config(tmp_path, port)

    world = KilledHost(tmp_path, ("--preset", "dc-servo"), config)
    host = world.host
    assert host is not None
    try:
        turning = lambda: sum(1 for _, cob, _ in list(world.frames) if cob == 0x181) > 200  # noqa: E731
        wait_for(lambda: turning() or host.poll() is not None, 60.0, "the run's TPDOs")
        held: dict[str, Any] = {}
        connected: dict[str, Any] = {}
        flood = [
            threading.Thread(target=lambda: held.update(hold(ports[0], 6.0, 200))),
            threading.Thread(target=lambda: connected.update(churn(ports[0], 60.0, count=2000))),
        ]
        for thread in flood:
            thread.start()
        code = host.wait(timeout=60)
        for thread in flood:
            thread.join()
        node = canopen.RemoteNode(1, CIA402_EDS)
        world.network.add_node(node)
        wait_for(lambda: node.sdo[0x6041].raw & 0x4F == 0x40, 10.0, "SWITCH ON DISABLED")
        wait_for(lambda: node.sdo[0x606C].raw == 0, 10.0, "the shaft at rest")
        per_rad = node.sdo[0x608F][1].raw / node.sdo[0x608F][2].raw / (2 * math.pi)
        final = node.sdo[0x6064].raw / per_rad
        node.tpdo.read(from_od=False)
        maps = {m.cob_id: m for m in node.tpdo.map.values() if m.enabled}
    finally:
        world.close()
    positions = []
    for _, cob, data in world.frames:
        m = maps.get(cob)
        var = next((v for v in m.map if v.index == 0x6064), None) if m is not None else None
        if var is not None:
            m.data = bytearray(data)
            positions.append(var.raw / per_rad)
    err = (tmp_path / "host.err").read_text()
    shaft = f"{min(positions):.2f}..{max(positions):.2f} rad, ends at {final:.3f}"
    stop = [line for line in err.splitlines() if "safe stop:" in line][-1:]
    print(f"run exit {code} {stop}; shaft {shaft}; {held}, {connected}")
    assert held["held"] == 200 and connected["connections"] == 2000, (held, connected)
    assert WINDOW[0] <= min(positions) and max(positions) <= WINDOW[1] and WINDOW[0] <= final <= WINDOW[1]
    assert code in (0, 3), err[-3000:]  # a clean end or a safe stop, confirmed
