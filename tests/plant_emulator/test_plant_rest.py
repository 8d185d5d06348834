"""Between runs the emulator's plant can be put back at rest (``rig emulate`` on SIGUSR1):
never while a drive is enabled, and no CANopen command does it (an NMT reset leaves the shaft
turning, as on a real drive)."""

from __future__ import annotations

import math
import signal

import canopen
import pytest

from drivers.maps import CIA402_EDS
from plant_emulator.lockstep import LockstepBench
from rig.emulator.serve import rest_plants
from rig.emulator.spawn import spawn_emulator, stop_rig


@pytest.mark.parametrize("preset", ["dc-servo", "dyno", "im-drive"])
def test_rest_after_a_run_and_not_during_one(preset: str) -> None:
    bench = LockstepBench(preset)
    try:
        node = canopen.RemoteNode(bench.devices[0].node_id, CIA402_EDS)
        bench.host.add_node(node)
        node.nmt.state = "OPERATIONAL"
        node.sdo[0x6060].raw = 9  # CSV
        for cw in (0x06, 0x0F):
            node.sdo[0x6040].raw = cw
        node.sdo[0x60FF].raw = round(20.0 * node.sdo[0x608F][1].raw / (2 * math.pi))
        for _ in range(1000):
            bench.sync()
        shaft = bench.devices[0].shaft  # type: ignore[attr-defined]
        assert abs(shaft.velocity) > 5.0
        assert rest_plants(bench.devices) is False  # enabled: refused
        assert abs(shaft.velocity) > 5.0
        node.nmt.state = "RESET"  # a reset lets go of the axis: the shaft coasts on
        bench.sync()
        assert abs(shaft.velocity) > 1.0 and abs(shaft.position) > 0.1
        assert rest_plants(bench.devices) is True
        assert shaft.velocity == 0.0 and shaft.position == 0.0
        for _ in range(10):
            bench.sync()
        assert shaft.velocity == 0.0
    finally:
        bench.close()


def test_sigusr1_puts_rig_emulate_s_plant_at_rest() -> None:
    proc, _port = spawn_emulator("--preset", "dc-servo")
    try:
        proc.send_signal(signal.SIGUSR1)
        assert proc.stdout is not None
        assert "the plant is back at rest" in proc.stdout.readline()
    finally:
        stop_rig(proc, timeout=10)
