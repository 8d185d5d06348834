"""socketcand across processes, by the wall clock (the ``timing`` tier; ``.ci/run`` runs it).

- ``rig scan`` against a server (a process of its own) that greets and then stalls: one line
  naming host:port, the connection closed by ``rig scan`` within 3 s of the server's accept
  (python-can's client waited for ever: over 25 s measured).
- ``rig emulate`` serving connection after connection from another process, and 200 at once,
  while a real-time run goes on against it (in this process): at least 200 a second, none lost.
- A client flooding ``rig emulate`` with frames from another process: held to the bus's bit rate,
  and a well-behaved reader (python-can's client, canopen SDO) keeps its connection and its answers.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from collections.abc import Iterator

import pytest

from rig.bench.socketcand import flood_beside_reader, flood_ceiling, realtime_run
from rig.bench.socketcand_clients import client_process, client_result
from rig.emulator.spawn import spawn_emulator, stop_rig

pytestmark = pytest.mark.timing

#: a server that greets and then says nothing: prints its port, then, once its one client has
#: gone, how long [s] the connection lasted
_STALLING_SERVER = """
import socket, sys, time
with socket.create_server(("127.0.0.1", 0)) as server:
    print(server.getsockname()[1], flush=True)
    link, _ = server.accept()
    accepted = time.monotonic()
    link.sendall(b"< hi >")
    while link.recv(4096):
        pass
    print(time.monotonic() - accepted, flush=True)
"""


def test_rig_scan_ends_within_3_s_when_a_server_greets_then_stalls() -> None:
    with subprocess.Popen(
        [sys.executable, "-c", _STALLING_SERVER], stdout=subprocess.PIPE, text=True
    ) as server:
        try:
            assert server.stdout is not None
            port = int(server.stdout.readline())
            scan = subprocess.run(
                [sys.executable, "-m", "rig.cli", "scan", "--interface", "socketcand", "--port", str(port)],
                capture_output=True,
                text=True,
                timeout=120,
                check=False,
            )
            connected = float(server.stdout.readline())
        finally:
            server.kill()
    assert scan.returncode == 1, scan.stderr
    lines = scan.stderr.strip().splitlines()
    said = f"127.0.0.1:{port} greeted, then sent no '< ok >' within 3 s"
    assert len(lines) == 1 and said in lines[0], lines
    assert connected < 3.3, connected  # 3 s, and the little it takes to close


@pytest.fixture(scope="module")
def emulator() -> Iterator[int]:
    proc, port = spawn_emulator("--preset", "dc-servo", "--param", "period=0.001")
    yield port
    stop_rig(proc, timeout=20)


def test_the_emulator_serves_200_connections_a_second_during_a_run(emulator: int) -> None:
    with tempfile.TemporaryDirectory() as out:
        churn = client_process("churn", emulator, 4.0)
        at_once = client_process("burst", emulator, 2.0, 200)
        realtime_run(out, emulator, 5.0)
        one_by_one, burst = client_result(churn), client_result(at_once)
    assert one_by_one["failed"] == 0 and one_by_one["connections"] / one_by_one["seconds"] >= 200, one_by_one
    assert burst["failed"] == 0 and burst["seconds"] < 1.0, burst


@pytest.mark.parametrize("bitrate", [1_000_000, 125_000])
def test_a_flood_is_held_to_the_bit_rate_and_a_reader_keeps_its_connection(bitrate: int) -> None:
    """The flood offers more than the bus carries; the reader sees the bus carry no more than its
    bit rate (at 125 kbit/s, 926 frames/s, the bus and not the emulator's speed is the limit:
    close to it), and keeps its connection and its SDO answers (its requests win every
    arbitration against the flood's 0x7FF)."""
    proc, port = spawn_emulator("--preset", "dc-servo", "--param", "period=0.001", "--bitrate", str(bitrate))
    try:
        offered, got = flood_beside_reader(port, bitrate)
    finally:
        stop_rig(proc, timeout=20)
    ceiling = flood_ceiling(bitrate)  # 8-byte standard frames: the flood's and the SDO's
    assert got["dropped"] == 0 and got["reads"] > 100, got
    assert offered["frames_per_s"] > ceiling, offered  # it did offer more than the bus carries
    assert got["frames"] > 0 and got["bus_frames_per_s"] <= ceiling * 1.05, (got, ceiling)
    if bitrate == 125_000:
        assert got["bus_frames_per_s"] >= ceiling * 0.5, (got, ceiling)  # the bus, not the emulator, limits
