"""A drive met without its EDS, across real processes: ``rig emulate --device nanotec-c5e`` (a drive
in tenths of a degree and rpm) in a process of its own behind its socketcand server, and ``rig
drive`` in others with no ``--eds``. Its units are read from the device, so a jog of 5 rad/s for
1 s turns the shaft 5 rad/s for 1 s (within 10 %), measured by the device's own raw 0x6064; a
move's speed goes to the device's own profile velocity 0x6081 (which the toolkit's EDS lacks), so a
move arrives where it was asked; and an EDS of another device is refused before anything is
written."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from drivers.maps import CIA402_EDS
from rig.emulator.spawn import spawn_emulator, stop_rig

pytestmark = pytest.mark.timing  #: a real bus: the jog's second is the wall clock's

TENTHS_OF_A_DEGREE_PER_RAD = 1800.0 / math.pi


def _rig(port: int, *argv: str) -> subprocess.CompletedProcess[str]:
    bus = ["--interface", "socketcand", "--channel", "can0", "--host", "127.0.0.1", "--port", str(port)]
    return subprocess.run(
        [sys.executable, "-m", "rig.cli", "drive", *bus, *argv],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def _raw_position(port: int) -> int:
    read = _rig(port, "--json", "sdo", "read", "0x6064")
    assert read.returncode == 0, read.stderr
    return int(json.loads(read.stdout)["value"])


def test_a_jog_without_an_eds_moves_as_asked() -> None:
    emulator, port = spawn_emulator("--device", "nanotec-c5e")
    try:
        status = _rig(port, "--json", "status")
        assert status.returncode == 0, status.stderr
        units = json.loads(status.stdout)["units"]
        assert units["from"]["position"] == "0x60A8" and units["from"]["velocity"] == "0x60A9"
        before = _raw_position(port)
        jog = _rig(port, "--json", "jog", "5", "--for", "1")
        assert jog.returncode == 0, jog.stderr
        r = json.loads(jog.stdout)
        assert r["result"] == "done" and r["stop_confirmed"] is True
        assert r["reached_rad_s"] == pytest.approx(5.0, rel=0.1)
        travel = (_raw_position(port) - before) / TENTHS_OF_A_DEGREE_PER_RAD  # [rad], the device's own unit
        # 1 s at 5 rad/s, and what the SDO round trips add to the second (the wall clock's, here)
        assert 4.5 <= travel <= 5.75, travel  # 5.04-5.10 rad here, quiet
        refused = _rig(port, "--eds", CIA402_EDS, "jog", "5", "--for", "1")
        assert refused.returncode == 2
        assert "is vendor 0x0000026C" in refused.stderr and "give the device's own EDS/DCF" in refused.stderr
        assert _raw_position(port) == _raw_position(port)  # at rest: nothing moved it
    finally:
        stop_rig(emulator)


def test_a_move_without_an_eds_arrives_where_asked() -> None:
    """``move 1 --relative`` (the drive's 0x6081 above --max-speed: the limit written to it in rpm)
    and ``move`` back at ``--speed 5``: each arrives within 10 % of the request, measured by the
    device's raw 0x6064 in tenths of a degree (was refused: 0x6081 is not in the toolkit's EDS)."""
    emulator, port = spawn_emulator("--device", "nanotec-c5e")
    try:
        before = _raw_position(port)
        there = _rig(port, "--json", "move", "1", "--relative")
        assert there.returncode == 0, there.stderr
        r = json.loads(there.stdout)
        assert r["result"] == "done" and r["stop_confirmed"] is True and r["speed_rad_s"] == 20.0
        travel = (_raw_position(port) - before) / TENTHS_OF_A_DEGREE_PER_RAD  # [rad]
        assert travel == pytest.approx(1.0, rel=0.1), travel
        back = _rig(port, "--json", "move", str(before / TENTHS_OF_A_DEGREE_PER_RAD), "--speed", "5")
        assert back.returncode == 0, back.stderr
        assert json.loads(back.stdout)["speed_rad_s"] == 5.0
        assert abs(_raw_position(port) - before) <= 0.1 * TENTHS_OF_A_DEGREE_PER_RAD
    finally:
        stop_rig(emulator)
