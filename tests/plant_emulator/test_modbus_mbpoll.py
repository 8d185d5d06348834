"""The emulated inverter with mbpoll (libmodbus) as the peer, where it is installed (Debian: apt-get
install mbpoll): a client we did not write, over TCP with the unit ids libmodbus uses, and over RTU."""

from __future__ import annotations

import gc
import shutil
import subprocess

import pytest

from plant_emulator.modbus_inverter import InverterServer, default_model
from plant_emulator.pty_link import PtyLink

pytestmark = pytest.mark.skipif(shutil.which("mbpoll") is None, reason="mbpoll is not installed")


def mbpoll(*args: str) -> str:
    """mbpoll once with 0-based references; its output (fails on its exit code, naming it)."""
    command = ["mbpoll", "-1", "-0", "-o", "5", *args]
    done = subprocess.run(command, check=False, capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, f"{' '.join(command)}: exit {done.returncode}: {done.stdout}{done.stderr}"
    return done.stdout


@pytest.mark.parametrize("unit", ["255", "0", "1"])
def test_tcp_write_and_read_back(unit: str) -> None:
    with InverterServer(default_model("abb-drives-profile")) as server:
        where = ["-m", "tcp", "-a", unit, "-p", str(server.port), "127.0.0.1"]
        mbpoll("-r", "1", *where, "2000")  # speed reference (write single register)
        assert "[1]: \t2000" in mbpoll("-r", "1", "-c", "1", *where)
    gc.collect()


def test_rtu_write_and_read_back() -> None:
    with PtyLink() as link, InverterServer(default_model("delta-vfd-b"), serial=link.port_a, unit=3):
        where = ["-m", "rtu", "-a", "3", "-b", "19200", "-P", "none", link.port_b]
        mbpoll("-r", "8193", *where, "1500")  # 2001H frequency command, 15.00 Hz
        assert "[8193]: \t1500" in mbpoll("-r", "8193", "-c", "1", *where)
    gc.collect()
