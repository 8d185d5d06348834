"""Malformed Modbus TCP frames at the emulated inverter's server (pymodbus, with
``plant_emulator.modbus_framing``): each is answered with the exception the application protocol
gives, or closes its connection, with one warning line naming the peer and the frame; never an
asyncio "data_received() call failed" traceback; the other clients keep their answers (issue 33:
four frames, MBAP length 2, FC 0x08 and 0x2B without data, gave tracebacks in the emulator's log).

Raw sockets against the real server in this process, generated frames (hypothesis), and the four
frames of the issue against ``rig emulate --modbus-map`` in a process of its own.
"""

from __future__ import annotations

import gc
import logging
import socket
import struct
import time
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from plant_emulator.modbus_inverter import InverterServer, default_model
from plant_emulator.pty_link import PtyLink
from rig.emulator.spawn import spawn_rig, stop_rig
from tests.plant_emulator.test_modbus_spec import Line, rtu

DEADLINE = 30.0  #: [s] a guard against a hang on every wait for bytes that must come (or the end)
STATUS = 3  #: the ABB drives profile's status word (holding register, 0-based)
FUZZ = settings(max_examples=120, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))


def mbap(tid: int, pdu: bytes, *, unit: int = 1, pid: int = 0, length: int | None = None) -> bytes:
    return struct.pack(">HHHB", tid, pid, len(pdu) + 1 if length is None else length, unit) + pdu


def exchange(port: int, data: bytes) -> tuple[bytes, int]:
    """Send ``data`` on a fresh connection and end the sending side; every byte answered until the
    server closes (the answers, then the end), and the client's port (as the server's log names it)."""
    with socket.create_connection(("127.0.0.1", port), timeout=DEADLINE) as sock:
        sock.sendall(data)
        sock.shutdown(socket.SHUT_WR)
        answered = b""
        end = time.monotonic() + DEADLINE
        while time.monotonic() < end:
            chunk = sock.recv(4096)
            if not chunk:
                break
            answered += chunk
        return answered, int(sock.getsockname()[1])


def answer_of(port: int, data: bytes) -> tuple[bytes | None, int]:
    """The one ADU answered to ``data`` on a connection kept open (None: the server closed it)."""
    with socket.create_connection(("127.0.0.1", port), timeout=DEADLINE) as sock:
        sock.sendall(data)
        got = b""
        while len(got) < 6 or len(got) < 6 + struct.unpack_from(">H", got, 4)[0]:
            chunk = sock.recv(4096)
            if not chunk:
                return None, int(sock.getsockname()[1])
            got += chunk
        return got, int(sock.getsockname()[1])


@pytest.fixture
def server() -> Iterator[InverterServer]:
    with InverterServer(default_model("abb-drives-profile"), unit=1) as served:
        yield served
    gc.collect()


def status_still_answered(port: int) -> None:
    client = ModbusTcpClient("127.0.0.1", port=port, timeout=DEADLINE)
    assert client.connect()
    rr = client.read_holding_registers(STATUS, count=1, device_id=1)
    client.close()
    assert not rr.isError() and len(rr.registers) == 1, rr


def told(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "plant_emulator.modbus_framing"]


def failed(caplog: pytest.LogCaptureFixture) -> list[str]:
    """The server side's errors: asyncio's (a protocol or a task that raised) and the emulator's."""
    return [
        r.getMessage()
        for r in caplog.records
        if r.levelno >= logging.ERROR and r.name.split(".")[0] in ("asyncio", "plant_emulator")
    ]


@pytest.mark.parametrize(
    ("frame", "answer", "why"),
    [
        (
            mbap(1, b"\x03"),
            mbap(1, b"\x83\x03"),
            "function 0x03 with 0 data bytes (its request: 4): exception 03",
        ),
        (mbap(2, b"\x08"), mbap(2, b"\x88\x03"), "function 0x08 without its sub-function: exception 03"),
        (
            mbap(3, b"\x2b"),
            mbap(3, b"\xab\x03"),
            "function 0x2B without its MEI type and codes: exception 03",
        ),
        (
            mbap(4, b"\x10\x00"),
            mbap(4, b"\x90\x03"),
            "function 0x10 with 1 data bytes (at least 5): exception 03",
        ),
        (mbap(5, b"\x03\x00\x03\x00\x01ab"), mbap(5, b"\x83\x03"), "with 6 data bytes (its request: 4)"),
        (
            mbap(6, b"\x41\x00"),
            mbap(6, b"\xc1\x01"),
            "function code 0x41 is not one the server has: exception 01",
        ),
        (mbap(7, b"\x10\x00\x00\x00\x7c\xf8" + bytes(248)), mbap(7, b"\x90\x03"), "a PDU of 254 bytes"),
        (mbap(8, b"", length=1), None, "MBAP length 1: no function code: connection closed"),
        (mbap(9, b"\x03\x00\x03\x00\x01", pid=5), None, "protocol id 5, not Modbus: connection closed"),
        (mbap(10, b"\x83\x02"), None, "function code 0x83 is an exception answer's: connection closed"),
        (mbap(11, b"\x03", length=0xFFFF), None, "MBAP length 65535: more than 260: connection closed"),
    ],
    ids=[
        "length-2-read", "fc08-alone", "fc2b-alone", "fc10-short", "read-too-long", "unknown-fc",
        "pdu-254", "length-1", "protocol-5", "fc83", "length-65535",
    ],
)  # fmt: skip
def test_a_malformed_frame_gets_its_exception_or_its_connection_closed_in_one_line(
    server: InverterServer,
    caplog: pytest.LogCaptureFixture,
    frame: bytes,
    answer: bytes | None,
    why: str,
) -> None:
    caplog.set_level(logging.WARNING)
    got, client_port = answer_of(server.port, frame)
    assert got == answer
    [line] = told(caplog)
    assert line.startswith(f"Modbus TCP 127.0.0.1:{client_port}: frame {frame[:8].hex(' ')}") and why in line
    assert not failed(caplog)
    status_still_answered(server.port)


def test_requests_before_a_frame_that_is_no_modbus_are_answered_then_the_connection_closes(
    server: InverterServer,
) -> None:
    read = b"\x03\x00\x03\x00\x01"
    answered, _ = exchange(server.port, mbap(1, read) + mbap(2, read) + mbap(3, read, pid=7) + mbap(4, read))
    tids = []
    while answered:
        tid, _pid, length = struct.unpack_from(">HHH", answered)
        tids.append(tid)
        answered = answered[6 + length :]
    assert tids == [1, 2]


@pytest.mark.parametrize(
    ("pdu", "why"), [(b"\x08", "without its sub-function"), (b"\x2b", "without its MEI")]
)
def test_on_rtu_too(caplog: pytest.LogCaptureFixture, pdu: bytes, why: str) -> None:
    """A frame whose CRC checks but whose request is cut short: exception 03 on the line, one line
    naming the serial device."""
    caplog.set_level(logging.WARNING)
    with PtyLink() as link, InverterServer(default_model("abb-drives-profile"), serial=link.port_a, unit=3):
        master = Line(link.port_b)
        try:
            master.send(rtu(3, pdu))
            assert master.receive(5) == rtu(3, bytes([pdu[0] | 0x80, 3]))
        finally:
            master.close()
    [line] = told(caplog)
    assert line.startswith(f"Modbus RTU {link.port_a}: frame {rtu(3, pdu)[:2].hex(' ')}") and why in line
    gc.collect()


frames = st.one_of(
    st.binary(max_size=40),
    st.builds(
        lambda tid, pid, unit, pdu, extra: mbap(tid, pdu, unit=unit, pid=pid) + extra,
        st.integers(0, 0xFFFF),
        st.sampled_from([0, 0, 0, 1]),
        st.sampled_from([0, 1, 7, 0xFF]),
        st.one_of(
            st.binary(max_size=12),
            st.builds(
                lambda fc, rest: bytes([fc]) + rest,
                st.sampled_from(
                    [1, 2, 3, 4, 5, 6, 7, 8, 11, 12, 15, 16, 17, 20, 21, 22, 23, 24, 43, 0x41, 0x83]
                ),
                st.binary(max_size=10),
            ),
        ),
        st.binary(max_size=8),
    ),
    st.builds(
        lambda length, rest: struct.pack(">HHH", 1, 0, length) + rest,
        st.integers(0, 0xFFFF),
        st.binary(max_size=8),
    ),
)


@FUZZ
@given(st.lists(frames, min_size=1, max_size=3).map(b"".join))
def test_generated_frames_never_break_the_server(
    server: InverterServer, caplog: pytest.LogCaptureFixture, data: bytes
) -> None:
    caplog.set_level(logging.WARNING)
    caplog.clear()
    answered, _ = exchange(server.port, data)
    while len(answered) >= 7:  # whatever is answered is Modbus: MBAP, protocol 0, a whole ADU
        _tid, pid, length = struct.unpack_from(">HHH", answered)
        assert pid == 0 and len(answered) >= 6 + length >= 8
        answered = answered[6 + length :]
    assert answered == b""
    assert not failed(caplog)
    assert all("\n" not in line for line in told(caplog))
    status_still_answered(server.port)


def test_the_issue_s_four_frames_leave_one_line_each_in_rig_emulate_s_log() -> None:
    """Across processes: ``rig emulate --modbus-map`` as a lab runs it; the four frames of issue 33
    (MBAP length 2 with a read's code alone, FC 0x08 and 0x2B without data, and a length of 1), then
    a client's read; Ctrl-C; its stderr holds one line per frame and no traceback."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc, line = spawn_rig("emulate", "--modbus-map", "abb-drives-profile", "--port", str(port), stderr=True)
    try:
        assert f"TCP 127.0.0.1:{port}" in line, line
        end = time.monotonic() + 30.0  # it prints before it listens
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
                break
            except OSError:
                assert time.monotonic() < end, "rig emulate never listened"
                time.sleep(0.05)
        sent = [mbap(1, b"\x03"), mbap(2, b"\x08"), mbap(3, b"\x2b"), mbap(4, b"", length=1)]
        got = [answer_of(port, frame)[0] for frame in sent]
        assert got == [mbap(1, b"\x83\x03"), mbap(2, b"\x88\x03"), mbap(3, b"\xab\x03"), None]
        status_still_answered(port)
    finally:
        out, err = stop_rig(proc, timeout=20)
    assert "stopped" in out, err
    assert "Traceback" not in err and "Fatal error" not in err, err
    lines = [line for line in err.splitlines() if "modbus_framing" in line]
    assert len(lines) == 4 and len(err.strip().splitlines()) == 4, err
    assert all(f"frame {frame[:7].hex(' ')}" in said for frame, said in zip(sent, lines)), lines
