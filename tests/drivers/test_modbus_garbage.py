"""The host's Modbus inverter driver against a TCP server that answers garbage: every answer that is
not the answer to what was asked (another function, another number of registers, not the write's
echo, bytes pymodbus cannot decode, a closed connection) is a toolkit error in one line naming the
unit, never another exception and never a value taken (issue 33, inputs that lie).

The server (a plain socket, written here) reads each request by its MBAP length, answers the first
with a sound answer and the second with what the test gives, then closes the connection, so the
client never waits out its timeout.
"""

from __future__ import annotations

import math
import socket
import socketserver
import struct
import threading
from collections.abc import Callable, Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.errors import CommunicationError, RigError
from drivers.modbus_inverter import ModbusInverterAxis

Answer = Callable[[int, bytes], bytes]  #: (transaction id, request PDU) -> the bytes answered
FUZZ = settings(max_examples=200, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))


def mbap(tid: int, unit: int, pdu: bytes, pid: int = 0) -> bytes:
    return struct.pack(">HHHB", tid, pid, len(pdu) + 1, unit) + pdu


def sound(tid: int, pdu: bytes) -> bytes:
    """The answer a well-behaved inverter gives: registers of 7 to a read, the echo of a write."""
    if pdu[0] == 3:
        count = int.from_bytes(pdu[3:5], "big")
        return mbap(tid, 1, bytes([3, 2 * count]) + b"\x00\x07" * count)
    return mbap(tid, 1, pdu)


class _Garbage(socketserver.ThreadingTCPServer):
    daemon_threads = True
    allow_reuse_address = True
    answer: Answer  #: set by each test (the fixture: ``sound``)


class _Client(socketserver.BaseRequestHandler):
    def _read(self, n: int) -> bytes | None:
        data = b""
        while len(data) < n:
            chunk = self.request.recv(n - len(data))
            if not chunk:
                return None
            data += chunk
        return data

    def handle(self) -> None:
        for turn in range(2):
            head = self._read(7)
            if head is None:
                return
            tid, _pid, length, _unit = struct.unpack(">HHHB", head)
            pdu = self._read(length - 1)
            if pdu is None:
                return
            server = self.server
            assert isinstance(server, _Garbage)
            self.request.sendall(sound(tid, pdu) if turn == 0 else server.answer(tid, pdu))
        self.request.shutdown(socket.SHUT_WR)  # then closed: the client reads the end at once


@pytest.fixture(scope="module")
def garbage() -> Iterator[_Garbage]:
    server = _Garbage(("127.0.0.1", 0), _Client)
    server.answer = sound
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


def _asked(garbage: _Garbage, answer: Answer, call: Callable[[ModbusInverterAxis], float | None]) -> None:
    garbage.answer = answer
    axis = ModbusInverterAxis(
        "inverter", "abb-drives-profile", host="127.0.0.1", port=garbage.server_address[1]
    )
    axis.disable = lambda: None  # type: ignore[method-assign]  # the connection is gone by then
    try:
        axis.setup()  # the sound answer
        value = call(axis)
        assert value is None or math.isfinite(value)
    except RigError as exc:
        said = str(exc)
        assert "\n" not in said and f"127.0.0.1:{garbage.server_address[1]}" in said, said
        raise
    finally:
        axis.close()


@pytest.mark.parametrize(
    ("answer", "said"),
    [
        (lambda t, p: mbap(t, 1, b"\x06\x00\x03\x00\x07"), "is one of function 6, not 3"),
        (lambda t, p: mbap(t, 1, b"\x03\xfa" + bytes(250)), "does not hold 1 16-bit register value(s)"),
        (lambda t, p: mbap(t, 1, b"\x03"), "no answer reading status_word (register 3)"),
        (lambda t, p: mbap(t + 1, 1, b"\x03\x02\x00\x07"), "no answer reading status_word (register 3)"),
        (lambda t, p: b"\x01\x02\x03", "no answer reading status_word (register 3)"),
    ],
)
def test_a_read_answered_with_garbage_is_one_line(garbage: _Garbage, answer: Answer, said: str) -> None:
    with pytest.raises(RigError, match=said.replace("(", r"\(").replace(")", r"\)")):
        _asked(garbage, answer, lambda axis: axis.read("status_word"))


def test_a_write_answered_with_another_echo_is_one_line(garbage: _Garbage) -> None:
    with pytest.raises(CommunicationError, match=r"is not the echo of 0 to register 1: \[5\] to 1"):
        _asked(
            garbage, lambda t, p: mbap(t, 1, b"\x06\x00\x01\x00\x05"), lambda a: a.write("speed_reference", 0)
        )


codes = st.sampled_from([1, 2, 3, 4, 5, 6, 8, 15, 16, 23, 43, 0x41, 0x83, 0x86])
pdus = st.one_of(
    st.builds(lambda fc, rest: bytes([fc]) + rest, codes, st.binary(max_size=9)),
    st.builds(lambda n, regs: bytes([3, n]) + regs, st.integers(0, 255), st.binary(max_size=12)),
)
framed = pdus.map(lambda pdu: lambda t, p: mbap(t, 1, pdu))  # the transaction's, unit 1: decoded
answers = st.one_of(
    framed,
    framed,
    st.binary(max_size=16).map(lambda raw: lambda t, p: raw),
    st.tuples(st.integers(-1, 1), st.sampled_from([0, 7]), st.sampled_from([1, 9]), pdus).map(
        lambda a: lambda t, p: mbap((t + a[0]) & 0xFFFF, a[2], a[3], pid=a[1])
    ),
)


@FUZZ
@given(answers, st.sampled_from(["read", "write", "feedback"]))
def test_garbage_answers_are_a_value_or_one_line(garbage: _Garbage, answer: Answer, call: str) -> None:
    calls: dict[str, Callable[[ModbusInverterAxis], float | None]] = {
        "read": lambda a: a.read("status_word"),
        "write": lambda a: a.write("speed_reference", 0.0),
        "feedback": lambda a: a.feedback().velocity,
    }
    try:
        _asked(garbage, answer, calls[call])
    except RigError:
        pass
