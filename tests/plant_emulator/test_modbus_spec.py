"""The emulated inverter against the Modbus specifications, with pymodbus' clients as the peer and raw
bytes where no client would send them (two requests in one segment, noise, broadcast, other units).

Application protocol V1.1b3 (exception order: function 01, quantity 03, address 02), serial line
V1.02 (silence for other addresses, broadcast without answer, CRC), TCP/IP implementation guide
V1.0b (unit 0xFF and 0 for a directly addressed server, MBAP length delimits each ADU).
Every wait is on a condition (the bytes expected) with a generous deadline.
"""

from __future__ import annotations

import gc
import os
import random
import select
import socket
import struct
import time
import tty
from collections.abc import Iterator

import pytest
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.framer import FramerType
from pymodbus.framer.rtu import FramerRTU

from plant_emulator.modbus_inverter import InverterServer, default_model
from plant_emulator.pty_link import PtyLink

DEADLINE = 5.0  # [s] for any answer that must come
STATUS, REF = 3, 1  # ABB drives profile: status word, speed reference (0-based holding registers)


def mbap(tid: int, unit: int, pdu: bytes) -> bytes:
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu


def rtu(address: int, pdu: bytes) -> bytes:
    frame = bytes([address]) + pdu
    return frame + FramerRTU.compute_CRC(frame).to_bytes(2, "big")


def read_holding(address: int, count: int) -> bytes:
    return struct.pack(">BHH", 3, address, count)


def write_single(address: int, value: int) -> bytes:
    return struct.pack(">BHH", 6, address, value)


# --- TCP ------------------------------------------------------------------------------------------
@pytest.fixture
def tcp() -> Iterator[InverterServer]:
    with InverterServer(default_model("abb-drives-profile"), unit=1) as server:
        yield server
    gc.collect()


def adus(sock: socket.socket, n: int) -> list[tuple[int, int, bytes]]:
    """The next ``n`` ADUs from ``sock``: (transaction id, unit, PDU) each."""
    data, out = b"", []
    deadline = time.monotonic() + DEADLINE
    while len(out) < n:
        while len(data) >= 6 and len(data) >= 6 + struct.unpack_from(">H", data, 4)[0]:
            tid, _, length, unit = struct.unpack_from(">HHHB", data)
            out.append((tid, unit, data[7 : 6 + length]))
            data = data[6 + length :]
        if len(out) >= n:
            break
        sock.settimeout(max(0.01, deadline - time.monotonic()))
        chunk = sock.recv(4096)
        assert chunk, f"connection closed after {len(out)} of {n} answers"
        data += chunk
    assert not data
    return out


def test_tcp_units_0xff_and_0_address_the_server_another_gets_0b(tcp: InverterServer) -> None:
    client = ModbusTcpClient("127.0.0.1", port=tcp.port, timeout=DEADLINE)
    assert client.connect()
    for unit in (0xFF, 0, 1):
        rr = client.read_holding_registers(STATUS, count=1, device_id=unit)
        assert not rr.isError() and rr.dev_id == unit, (unit, rr)
    rr = client.read_holding_registers(STATUS, count=1, device_id=7)
    assert rr.isError() and rr.exception_code == 0x0B
    client.close()


def test_tcp_several_requests_in_one_segment_are_each_answered_in_order(tcp: InverterServer) -> None:
    with socket.create_connection(("127.0.0.1", tcp.port), timeout=DEADLINE) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        burst = [mbap(10, 1, write_single(REF, 2000)), mbap(11, 0xFF, read_holding(REF, 1))]
        third = mbap(12, 0, read_holding(STATUS, 1))
        sock.sendall(b"".join(burst) + third[:5])  # two and a bit in one segment
        first = adus(sock, 2)
        sock.sendall(third[5:])  # the rest of the third request
        answers = first + adus(sock, 1)
    assert [(tid, unit) for tid, unit, _ in answers] == [(10, 1), (11, 0xFF), (12, 0)]
    assert answers[0][2] == write_single(REF, 2000)  # the echo of a write
    assert answers[1][2] == bytes([3, 2]) + (2000).to_bytes(2, "big")


@pytest.mark.parametrize(
    ("pdu", "code"),
    [
        (read_holding(0, 0), 3),  # quantity 0
        (read_holding(0, 126), 3),  # over 125: 03 before 02 (registers 0..125 do not all exist)
        (struct.pack(">BHH", 4, 0, 0), 3),  # read input registers, quantity 0
        (struct.pack(">BHHB", 16, 0, 0, 0), 3),  # write multiple, quantity 0
        (struct.pack(">BHHB", 16, 0, 124, 248) + bytes(248), 3),  # write multiple over 123
        (struct.pack(">BHHB", 16, 0, 1, 4) + bytes(4), 3),  # byte count not 2 x quantity
        (struct.pack(">BHH", 1, 0, 3000), 1),  # coils: the inverter has none, 01 comes before 03
        (struct.pack(">BHH", 1, 0, 1), 1),
        (read_holding(50, 1), 2),  # no such register
        (bytes([0x41, 0, 0]), 1),  # a function code nobody defines
    ],
)
def test_tcp_exception_codes_in_the_order_of_the_specification(
    tcp: InverterServer, pdu: bytes, code: int
) -> None:
    with socket.create_connection(("127.0.0.1", tcp.port), timeout=DEADLINE) as sock:
        sock.sendall(mbap(77, 1, pdu))
        [(tid, unit, answer)] = adus(sock, 1)
    assert (tid, unit, answer) == (77, 1, bytes([pdu[0] | 0x80, code]))


def test_tcp_pymodbus_client_over_the_limits(tcp: InverterServer) -> None:
    client = ModbusTcpClient("127.0.0.1", port=tcp.port, timeout=DEADLINE)
    assert client.connect()
    rr = client.write_registers(0, [0] * 124, device_id=1)  # pymodbus' client does not check this one
    assert rr.isError() and rr.exception_code == 3
    assert not client.read_holding_registers(STATUS, count=1, device_id=1).isError()  # still in step
    client.close()


# --- RTU ------------------------------------------------------------------------------------------
class Line:
    """The master's end of the pty pair, raw."""

    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)

    def send(self, data: bytes) -> None:
        os.write(self.fd, data)

    def receive(self, n: int) -> bytes:
        """Exactly ``n`` bytes (fails after the deadline with what came)."""
        data = b""
        deadline = time.monotonic() + DEADLINE
        while len(data) < n and time.monotonic() < deadline:
            ready, _, _ = select.select([self.fd], [], [], deadline - time.monotonic())
            if ready:
                data += os.read(self.fd, n - len(data))
        assert len(data) == n, f"expected {n} bytes, got {data.hex()}"
        return data

    def close(self) -> None:
        os.close(self.fd)


@pytest.fixture
def line() -> Iterator[Line]:
    with PtyLink() as link, InverterServer(default_model("abb-drives-profile"), serial=link.port_a, unit=3):
        master = Line(link.port_b)
        yield master
        master.close()
    gc.collect()


def status_answer(line: Line) -> bytes:
    """Ask unit 3 for its status word; its answer (7 bytes, checked)."""
    line.send(rtu(3, read_holding(STATUS, 1)))
    answer = line.receive(7)
    assert answer[:3] == bytes([3, 3, 2]) and answer == rtu(3, answer[1:5]), answer.hex()
    return answer


def test_rtu_other_addresses_get_silence_and_a_broadcast_is_applied_unanswered(line: Line) -> None:
    line.send(rtu(4, read_holding(STATUS, 1)))  # another server's request: silence
    line.send(rtu(0, write_single(REF, 1234)))  # broadcast: applied, never answered
    line.send(rtu(3, read_holding(REF, 1)))
    # the first bytes on the line are the answer to the last request: nothing came before it
    assert line.receive(7) == rtu(3, bytes([3, 2]) + (1234).to_bytes(2, "big"))


@pytest.mark.parametrize("seed", range(8))
def test_rtu_resynchronises_after_line_noise(line: Line, seed: int) -> None:
    before = status_answer(line)
    rng = random.Random(seed)
    noise = bytes(rng.randrange(256) for _ in range(rng.choice((1, 7, 36, 300, 1000))))
    line.send(noise)
    assert status_answer(line) == before
    line.send(noise[:36])  # noise and a request in one write: found after the noise
    line.send(rtu(3, read_holding(STATUS, 1)))
    assert line.receive(7) == before


def test_rtu_noise_that_announces_a_long_frame_does_not_block(line: Line) -> None:
    before = status_answer(line)
    line.send(bytes([3, 16, 0, 0, 0, 120, 240]))  # a write of 240 bytes that never comes
    for _ in range(3):
        assert status_answer(line) == before  # each answered at once, not after 240 bytes


def test_rtu_a_corrupted_request_is_ignored_the_next_answered(line: Line) -> None:
    """A request whose CRC fails gets no answer: the first bytes on the line after it are the
    answer to the request that follows it, a read of another register holding a value of its own
    (a server that took the corrupted read of register 2 would put its answer first)."""
    line.send(rtu(3, write_single(REF, 1234)))
    assert line.receive(8) == rtu(3, write_single(REF, 1234))  # the write's echo
    bad = bytearray(rtu(3, read_holding(STATUS, 1)))
    bad[3] ^= 0x01  # a flipped bit: a well-formed read of register 2 whose CRC fails
    line.send(bytes(bad))
    line.send(rtu(3, read_holding(REF, 1)))
    assert line.receive(7) == rtu(3, bytes([3, 2]) + (1234).to_bytes(2, "big"))


def test_rtu_exceptions_unknown_function_and_quantity(line: Line) -> None:
    for pdu, code in ((bytes([0x41, 0, 0]), 1), (read_holding(0, 0), 3), (read_holding(0, 126), 3)):
        line.send(rtu(3, pdu))
        assert line.receive(5) == rtu(3, bytes([pdu[0] | 0x80, code]))


def test_rtu_with_pymodbus_serial_client_after_noise() -> None:
    with PtyLink() as link, InverterServer(default_model("delta-vfd-b"), serial=link.port_a, unit=3):
        noise = Line(link.port_b)
        noise.send(bytes(random.Random(36).randrange(256) for _ in range(36)))
        noise.close()
        client = ModbusSerialClient(
            link.port_b, framer=FramerType.RTU, baudrate=19200, timeout=DEADLINE, retries=0
        )
        assert client.connect()
        for value in (100, 200, 300):
            assert not client.write_register(0x2001, value, device_id=3).isError()
            assert client.read_holding_registers(0x2001, count=1, device_id=3).registers == [value]
        rr = client.write_registers(0x2001, [0] * 124, device_id=3)
        assert rr.isError() and rr.exception_code == 3
        client.close()
    gc.collect()


def test_server_units_it_cannot_be() -> None:
    model = default_model("abb-drives-profile")
    with pytest.raises(ValueError, match=r"unit 0: not 1\.\.247 on RTU"):
        InverterServer(model, serial="/dev/null", unit=0)
    with pytest.raises(ValueError, match=r"unit 256: not 0\.\.255 on TCP"):
        InverterServer(model, unit=256)
