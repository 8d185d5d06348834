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
import threading
import time
from collections.abc import Iterator
from typing import Any

import can
import pytest

from plant_emulator.bus_time import DEFAULT_BITRATE, frame_bits
from rig.bench.socketcand import _reader, _result, _run, client_process
from rig.process import spawn_emulator, stop_rig

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
        _run(out, emulator, 5.0)
        one_by_one, burst = _result(churn), _result(at_once)
    assert one_by_one["failed"] == 0 and one_by_one["connections"] / one_by_one["seconds"] >= 200, one_by_one
    assert burst["failed"] == 0 and burst["seconds"] < 1.0, burst


def test_a_flood_is_held_to_the_bit_rate_and_a_reader_keeps_its_connection(emulator: int) -> None:
    ceiling = DEFAULT_BITRATE / frame_bits(can.Message(arbitration_id=0x7FF, is_extended_id=False, dlc=8))
    got: dict[str, Any] = {}
    reader = threading.Thread(target=lambda: got.update(_reader(emulator, 6.0)))
    reader.start()
    time.sleep(1.0)  # the reader is connected and reading
    flood = client_process("flood", emulator, 4.0)
    offered = _result(flood)
    reader.join()
    assert got["dropped"] == 0 and got["reads"] > 100, got
    # what the reader saw of the flood, over the flood's time and the 2 s after it (the frames
    # the kernel still held): never faster than the bus carries
    assert got["frames"] <= ceiling * (offered["seconds"] + 2.0), (got, offered, ceiling)
    assert offered["frames_per_s"] > ceiling, offered  # it did offer more than the bus carries
