"""The emulated inverter with mbpoll (libmodbus, C) as the Modbus master: a client we did not write.

Two levels: ``InverterServer`` in this process (unit ids libmodbus uses on TCP, RTU on a
pty pair), and ``rig emulate --modbus-map NAME`` in its own process for each shipped map, over
TCP and over RTU on a socat pty pair (socat, not our own ``PtyLink``: a serial line nobody here
wrote either). Every value is checked against the map (``drivers/maps/*.json``): register
addresses, access, scaling of the speed reference, the status word's bits, the control words of
run, stop and fault reset. The exceptions the Modbus application protocol requires: 01 for a
function the server does not implement (coils), 02 for an address the map lacks and for a write
to a read-only register, 03 for a value out of the map's range. The communication-loss trip: a
running inverter that hears nothing for ``comm_loss_timeout`` stops with fault 0x6681, and the
map's reset clears it.

Installed from Debian: ``apt-get install mbpoll socat``.
"""

from __future__ import annotations

import gc
import pathlib
import socket
import subprocess
import time
from collections.abc import Iterator

import pytest

from drivers.maps import modbus_map
from plant_emulator.inverter_model import COMM_LOSS
from plant_emulator.modbus_inverter import InverterServer, default_model
from plant_emulator.pty_link import PtyLink
from rig.emulator.spawn import spawn_rig, stop_rig
from tests.interop.conftest import need_tools, wait_for

pytestmark = [pytest.mark.interop, pytest.mark.timeout(600)]  # the VM is slow

MAPS = ["abb-drives-profile", "delta-vfd-b"]
COMM_LOSS_TIMEOUT = 0.3  #: [s] for the trip test; the silence that trips it is three times as long

#: libmodbus's texts of the exception codes (modbus_strerror)
EXCEPTION_TEXT = {1: "Illegal function", 2: "Illegal data address", 3: "Illegal data value"}


@pytest.fixture(autouse=True)
def _mbpoll() -> None:
    need_tools("mbpoll")


def run_mbpoll(*args: str) -> subprocess.CompletedProcess[str]:
    command = ["mbpoll", "-1", "-0", "-o", "5", *args]
    return subprocess.run(command, check=False, capture_output=True, text=True, timeout=60)


def mbpoll(*args: str) -> str:
    """mbpoll once with 0-based references; its output (fails on its exit code, naming it)."""
    done = run_mbpoll(*args)
    assert done.returncode == 0, (
        f"mbpoll {' '.join(args)}: exit {done.returncode}: {done.stdout}{done.stderr}"
    )
    return done.stdout


def mbpoll_exception(*args: str) -> str:
    """mbpoll expected to get a Modbus exception: its message."""
    done = run_mbpoll(*args)
    text = done.stdout + done.stderr
    assert done.returncode != 0, f"mbpoll {' '.join(args)} succeeded: {text}"
    return text


def read(where: list[str], address: int, count: int = 1) -> list[int]:
    """Holding registers ``address``.. (unsigned, as mbpoll prints them with :hex)."""
    out = mbpoll("-t", "4:hex", "-r", str(address), "-c", str(count), *where)
    values = {}
    for line in out.splitlines():
        if line.startswith("[") and "]:" in line:
            ref, value = line.split("]:")
            values[int(ref[1:])] = int(value.strip(), 16)
    assert sorted(values) == list(range(address, address + count)), out
    return [values[a] for a in range(address, address + count)]


def write(where: list[str], address: int, value: int) -> None:
    mbpoll("-r", str(address), *where, "--", str(value))


# --- in-process server: unit ids and the pty line ------------------------------------------------
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


# --- rig emulate --modbus-map in its own process -------------------------------------------------
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def socat_line(tmp_path: pathlib.Path) -> Iterator[tuple[str, str]]:
    """A serial line of two ptys joined by socat: (the emulator's end, mbpoll's end)."""
    need_tools("socat")
    a, b = tmp_path / "ttyA", tmp_path / "ttyB"
    proc = subprocess.Popen(
        ["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    wait_for(lambda: (a.exists() and b.exists()) or proc.poll() is not None, "socat's two ptys")
    assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
    yield str(a), str(b)
    proc.terminate()
    proc.communicate(timeout=10)


@pytest.fixture(params=["tcp", "rtu"])
def inverter(request: pytest.FixtureRequest, tmp_path: pathlib.Path) -> Iterator[tuple[str, list[str]]]:
    """``rig emulate --modbus-map NAME`` (NAME from the test's ``family``) on TCP or on a socat line:
    (the map's name, mbpoll's arguments that reach it)."""
    family: str = request.node.callspec.params["family"]
    params = ["--param", f"comm_loss_timeout={COMM_LOSS_TIMEOUT}"]
    if request.param == "tcp":
        port = _free_port()
        args = ["--modbus-map", family, "--port", str(port), *params]
        where = ["-m", "tcp", "-a", "1", "-p", str(port), "127.0.0.1"]
    else:
        emulator_end, mbpoll_end = request.getfixturevalue("socat_line")
        args = ["--modbus-map", family, "--modbus-serial", emulator_end, *params]
        where = ["-m", "rtu", "-a", "1", "-b", "19200", "-P", "none", mbpoll_end]
    proc, line = spawn_rig("emulate", *args, stderr=True)
    try:
        assert "Modbus inverter" in line, line
        # listening once it answers: the first read is retried until it does
        wait_for(
            lambda: run_mbpoll("-r", str(modbus_map(family)["control_word"].address), *where).returncode == 0,
            f"rig emulate --modbus-map {family} to answer",
        )
        yield family, where
    finally:
        _out, err = stop_rig(proc)
        assert proc.returncode == 0, err


@pytest.mark.parametrize("family", MAPS)
def test_map_reads_writes_exceptions_and_comm_loss(family: str, inverter: tuple[str, list[str]]) -> None:
    _, where = inverter
    regmap = modbus_map(family)
    control = {k: int(v) for k, v in regmap.control.items() if isinstance(v, int)}
    status = {k: int(v) for k, v in regmap.status.items()}

    # every register of the map reads, one at a time; nothing else does (02)
    for reg in regmap.registers.values():
        read(where, reg.address)
    addresses = set(regmap.by_address())
    missing = next(a for a in range(max(addresses) + 1, max(addresses) + 100) if a not in addresses)
    assert EXCEPTION_TEXT[2] in mbpoll_exception("-r", str(missing), *where)
    # a read spanning a hole of the map is refused as a whole (02)
    hole = next(a for a in sorted(addresses) if a + 1 not in addresses)
    assert EXCEPTION_TEXT[2] in mbpoll_exception("-r", str(hole), "-c", "2", *where)
    # a read-only register refuses a write (02)
    ro = next(reg for reg in regmap.registers.values() if reg.access == "ro")
    assert EXCEPTION_TEXT[2] in mbpoll_exception("-r", str(ro.address), *where, "--", "1")
    # coils are not implemented (01), read or written
    assert EXCEPTION_TEXT[1] in mbpoll_exception("-t", "0", "-r", "0", *where)
    assert EXCEPTION_TEXT[1] in mbpoll_exception("-t", "0", "-r", "0", *where, "--", "1")

    # the speed reference: scaled as the map says, read back as written; out of range is 03
    ref = regmap["speed_reference"]
    raw = ref.to_raw(20.0)  # 20 rad/s
    write(where, ref.address, raw)
    assert read(where, ref.address) == [raw]
    assert ref.to_si(raw) == pytest.approx(20.0, rel=1e-2)
    too_fast = 0x7FFF if ref.signed else 0xFFFF
    assert EXCEPTION_TEXT[3] in mbpoll_exception("-r", str(ref.address), *where, "--", str(too_fast))
    assert read(where, ref.address) == [raw]  # the refused value was not taken

    # run: the status word says running as the map defines it
    cw = regmap["control_word"].address
    sw = regmap["status_word"].address
    if family == "abb-drives-profile":
        write(where, cw, control["stop"])
        write(where, cw, control["run"])
        running = 1 << status["running_bit"]
        ready = 1 << status["ready_bit"]
        assert read(where, sw)[0] & (running | ready) == running | ready
    else:
        write(where, cw, control["run"])
        assert read(where, sw)[0] & status["state_mask"] == status["running_value"]
    assert read(where, cw) == [control["run"]]

    # the communication-loss trip: silence for three times comm_loss_timeout (the stimulus)
    time.sleep(3 * COMM_LOSS_TIMEOUT)
    fault = regmap["fault_code"].address
    assert read(where, fault) == [COMM_LOSS]
    if family == "abb-drives-profile":
        assert read(where, sw)[0] & (1 << status["fault_bit"])
        assert not read(where, sw)[0] & (1 << status["running_bit"])
        write(where, cw, control["reset"])  # bit 7 rising: fault reset
    else:
        assert read(where, sw)[0] & status["state_mask"] != status["running_value"]
        write(where, regmap["fault_control"].address, control["reset"])  # 2002H bit 1: reset
    assert read(where, fault) == [0]
