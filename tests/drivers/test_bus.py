"""Opening a bus: python-can's socketcand client on a socketcand server of ours."""

from __future__ import annotations

import errno
import logging
import threading
import time

import can
import pytest

from drivers.bus import open_bus
from tests.drivers.scripted_socketcand import greet


def test_a_frame_split_across_tcp_segments_is_received_whole_and_no_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """TCP cuts lines where it likes (python-can's client warned "Got incomplete message" at
    every cut): a frame in two segments is one frame, the next whole one follows, nothing is
    logged, and what the host sends arrives as socketcand's ``< send ... >`` line."""
    import socket

    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]
        got: list[bytes] = []
        go = threading.Event()

        def serve() -> None:
            link, _ = server.accept()
            with link:
                greet(link)
                go.wait(5.0)
                link.sendall(b"< frame 181 12.500000 0102")
                time.sleep(0.05)  # the rest in a second segment
                link.sendall(b"FF >< frame 1ABCDEF0 12.600000  >")
                got.append(link.recv(256))

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)
        try:
            with caplog.at_level(logging.DEBUG, logger="can"), caplog.at_level(logging.INFO):
                go.set()
                first, second = bus.recv(2.0), bus.recv(2.0)
                bus.send(
                    can.Message(
                        arbitration_id=0x601,
                        is_extended_id=False,
                        data=bytes([0x40, 0x41, 0x60, 0, 0, 0, 0, 0]),
                    )
                )
                thread.join(5.0)
        finally:
            bus.shutdown()
    assert first is not None and second is not None
    assert (first.arbitration_id, bytes(first.data), first.timestamp, first.is_extended_id) == (
        0x181,
        bytes([1, 2, 0xFF]),
        12.5,
        False,
    )
    assert (second.arbitration_id, second.dlc, second.is_extended_id) == (0x1ABCDEF0, 0, True)
    assert got == [b"< send 601 8 40 41 60 00 00 00 00 00 >"]
    assert not [r for r in caplog.records if r.levelno >= logging.INFO]


def test_frame_lines_agree_with_python_cans_own_converters() -> None:
    """The lean path's lines and python-can's socketcand converters (software we did not write)
    agree on every kind of frame: what ``format_send`` writes, python-can's ``< send >`` parser in
    our server reads as the same frame; what ``parse_frames`` reads is what python-can's
    ``convert_ascii_message_to_can_message`` reads."""
    import collections

    from can.interfaces.socketcand.socketcand import (
        convert_ascii_message_to_can_message,
        convert_can_message_to_ascii_message,
    )

    from drivers.socketcand_client import format_send, parse_frames
    from plant_emulator.socketcand_protocol import format_frame, parse_send

    frames = [
        can.Message(arbitration_id=0x080, data=b"", is_extended_id=False),
        can.Message(
            arbitration_id=0x181, data=bytes([0x37, 0x06, 0xFF, 0x00, 0x10, 0x00]), is_extended_id=False
        ),
        can.Message(arbitration_id=0x7FF, data=bytes(range(8)), is_extended_id=False),
        can.Message(arbitration_id=0x1FFFFFFF, data=bytes([0xAB]), is_extended_id=True),
        can.Message(arbitration_id=0x00000001, data=bytes([0, 0]), is_extended_id=True),
    ]
    for msg in frames:
        ours, theirs = (
            parse_send(format_send(msg).decode()),
            parse_send(convert_can_message_to_ascii_message(msg)),
        )
        assert (ours.arbitration_id, ours.is_extended_id, bytes(ours.data), ours.dlc) == (
            theirs.arbitration_id,
            theirs.is_extended_id,
            bytes(theirs.data),
            theirs.dlc,
        )
        line = format_frame(msg, 1732600000.123456)
        out: collections.deque[can.Message] = collections.deque()
        assert parse_frames(line, "can0", out) == ""
        (mine,), ref = out, convert_ascii_message_to_can_message(line)
        assert (
            mine.arbitration_id,
            mine.is_extended_id,
            bytes(mine.data),
            mine.dlc,
            mine.timestamp,
            mine.is_rx,
        ) == (
            ref.arbitration_id,
            ref.is_extended_id,
            bytes(ref.data),
            ref.dlc,
            ref.timestamp,
            ref.is_rx,
        )


def test_nothing_listening_is_one_line_naming_host_and_port(caplog: pytest.LogCaptureFixture) -> None:
    """python-can's socketcand client retries a refused connection for 10 s with a warning per
    try (211,731 lines measured); open_bus tries once and names host:port."""
    import socket

    from drivers.errors import CommunicationError

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with caplog.at_level(logging.WARNING), pytest.raises(CommunicationError) as err:
        open_bus("socketcand", "can0", host="127.0.0.1", port=port)
    assert f"cannot reach a socketcand server at 127.0.0.1:{port}" in str(err.value)
    assert "is a socketcand server running there? Start one (rig emulate" in str(err.value)  # and the fix
    assert not caplog.records


@pytest.mark.parametrize(
    ("code", "fix"),
    [
        (errno.ENODEV, "sudo ip link add dev vcan7 type vcan; sudo ip link set up vcan7"),
        (errno.ENETDOWN, "the interface vcan7 is down: sudo ip link set up vcan7"),
        (errno.EAFNOSUPPORT, "this kernel offers no SocketCAN"),
        (errno.EPERM, "or use --interface socketcand beside rig emulate"),
    ],
)
def test_a_socketcan_interface_that_does_not_open_says_the_likely_cause_and_the_fix(
    code: int, fix: str
) -> None:
    """The errno python-can's socketcan raised becomes the cause and the fix (set up vcan, bring
    it up, load the module), not only the errno's words."""
    from drivers.bus import bus_fix

    assert fix in bus_fix("socketcan", "vcan7", OSError(code, "from the kernel"))


GREETINGS = [(None, "sent no greeting '< hi >' within 3 s"), (b"SSH-2.0\r\n", "is not a socketcand server")]


@pytest.mark.timeout(20)
@pytest.mark.parametrize(("greeting", "needle"), GREETINGS)
def test_a_server_that_does_not_greet_is_one_line(
    greeting: bytes | None, needle: str, caplog: pytest.LogCaptureFixture
) -> None:
    """A server that accepts the connection but never sends socketcand's ``< hi >`` (python-can
    would wait for it for ever), or sends something else: one line naming host:port."""
    _greetless(greeting, needle, caplog)


@pytest.mark.timing
@pytest.mark.timeout(20)
@pytest.mark.parametrize(("greeting", "needle"), GREETINGS)
def test_a_server_that_does_not_greet_is_one_line_within_3_s(
    greeting: bytes | None, needle: str, caplog: pytest.LogCaptureFixture
) -> None:
    """The same, in 3 s (a wall-clock bound: the timing tier)."""
    assert _greetless(greeting, needle, caplog) < 3.5


def _greetless(greeting: bytes | None, needle: str, caplog: pytest.LogCaptureFixture) -> float:
    """open_bus against such a server: its error checked; the seconds it took."""
    import socket
    import time

    from drivers.errors import CommunicationError

    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]
        held: list[socket.socket] = []

        def accept() -> None:
            link, _ = server.accept()
            held.append(link)
            if greeting:
                link.sendall(greeting)

        threading.Thread(target=accept, daemon=True).start()
        start = time.monotonic()
        with caplog.at_level(logging.WARNING), pytest.raises(CommunicationError) as err:
            open_bus("socketcand", "can0", host="127.0.0.1", port=port)
        elapsed = time.monotonic() - start
        for link in held:
            link.close()
    assert f"127.0.0.1:{port}" in str(err.value) and needle in str(err.value)
    assert "\n" not in str(err.value) and not caplog.records
    return elapsed


def test_an_unknown_interface_is_a_configuration_error_naming_the_known_ones() -> None:
    from drivers.errors import ConfigError

    with pytest.raises(
        ConfigError, match=r"interface 'nosuch': not a python-can interface; known: .*socketcan,"
    ):
        open_bus("nosuch", "x")


@pytest.mark.parametrize(
    ("answers", "awaited"),
    [([], "'< ok >'"), ([b"< ok >"], "'< ok >'"), ([b"< ok >", b"< ok >"], None)],
    ids=["stall-after-hi", "stall-after-open", "no-stall"],
)
def test_a_server_that_greets_then_stalls_is_one_line_within_the_handshake_time(
    answers: list[bytes],
    awaited: str | None,
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A server that sends ``< hi >`` and then answers ``< open can0 >`` or ``< rawmode >``
    never (python-can's client waits for ever: ``rig scan`` hung over 25 s): one line naming
    host:port and what did not come, once ``HANDSHAKE`` is over (0.3 s here; the bound itself
    is timed across processes in ``tests/rig/test_socketcand_processes.py``). A server that
    answers all is opened, and its socket blocks as python-can's does."""
    import socket

    import drivers.bus
    from drivers.errors import CommunicationError

    monkeypatch.setattr(drivers.bus, "HANDSHAKE", 0.3)
    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]
        held: list[socket.socket] = []

        def serve() -> None:
            link, _ = server.accept()
            held.append(link)
            greet(link, tuple(answers))

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        try:
            with caplog.at_level(logging.WARNING):
                if awaited is None:
                    bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)
                    assert bus._socket.gettimeout() is None  # type: ignore[attr-defined]
                    bus.shutdown()
                    return
                with pytest.raises(CommunicationError) as err:
                    open_bus("socketcand", "can0", host="127.0.0.1", port=port)
        finally:
            thread.join(5.0)
            for link in held:
                link.close()
    text = str(err.value)
    assert f"127.0.0.1:{port} greeted, then sent no {awaited} within 0.3 s" in text, text
    assert "\n" not in text and not caplog.records


def test_frames_right_behind_the_rawmode_ok_are_received_not_refused() -> None:
    """socketcand sends frames as they come, so on a busy bus they share a TCP segment with the
    rawmode ``< ok >`` (and the greeting may come cut in two): python-can's client refused that
    ("Expected '< ok >' got: '< ok >< frame ...'"); open_bus keeps them as frames received."""
    import socket

    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]
        held: list[socket.socket] = []

        def serve() -> None:
            link, _ = server.accept()
            held.append(link)
            link.sendall(b"< h")
            time.sleep(0.05)  # the greeting in two segments (decides nothing: any cut will do)
            link.sendall(b"i >")
            link.recv(256)
            link.sendall(b"< ok >")
            link.recv(256)
            link.sendall(b"< ok >< frame 123 1.000000 0102 >< frame 12345678 2.500000  >< frame 7")

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)
        try:
            first, second = bus.recv(1.0), bus.recv(1.0)
        finally:
            bus.shutdown()
            thread.join(5.0)
            for link in held:
                link.close()
    assert first is not None and first.arbitration_id == 0x123 and bytes(first.data) == b"\x01\x02"
    assert second is not None and second.arbitration_id == 0x12345678 and second.is_extended_id
    assert second.timestamp == 2.5 and first.channel == "can0"


def test_a_connection_the_server_closed_is_no_spin(caplog: pytest.LogCaptureFixture) -> None:
    """A socketcand server that closes the connection after a frame: the frame is received, then
    each receive waits its timeout and says once that the server closed the connection, where
    python-can's client returned at once, for ever (its receive thread spun: at real-time
    priority it starved the host's loop on its CPU, and a dropped link left ``rig run`` running
    for over 60 s instead of stopping at its next send)."""
    import socket

    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]

        def serve() -> None:
            link, _ = server.accept()
            with link:
                greet(link, (b"< ok >", b"< ok >< frame 123 1.000000 01 >"))

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)
        try:
            thread.join(5.0)
            frame = bus.recv(1.0)
            assert frame is not None and frame.arbitration_id == 0x123
            start = time.monotonic()
            with caplog.at_level(logging.WARNING):
                assert [bus.recv(0.05) for _ in range(4)] == [None] * 4
            assert time.monotonic() - start >= 0.15  # each waited (the first returns at the end-of-file)
            (record,) = caplog.records
            assert "the socketcand server closed the connection" in record.getMessage()
        finally:
            bus.shutdown()


def test_a_broken_line_does_not_swallow_the_frame_after_it(caplog: pytest.LogCaptureFixture) -> None:
    """A frame starts at the last ``<`` before its ``>``: an unfinished line in the stream (a
    broken server, a relay that cut one) costs only itself, not the whole frame that follows it
    (seen across processes through a relay adding such lines every 5 ms: the drive's TPDOs lost,
    800 late cycles in 2 s and the late-cycle stop), and an overlong unfinished rest keeps the
    frame that began at its end."""
    import collections

    from drivers.socketcand_client import parse_frames

    out: collections.deque[can.Message] = collections.deque()
    assert parse_frames("< frame 181< frame 181 1.000001 0102 >", "can0", out) == ""
    rest = parse_frames("x" * 300 + "< frame 182 1.000002 03", "can0", out)
    with caplog.at_level(logging.WARNING):
        assert parse_frames(rest + "04 >", "can0", out) == ""
    assert [(m.arbitration_id, bytes(m.data).hex()) for m in out] == [(0x181, "0102"), (0x182, "0304")]


@pytest.mark.parametrize(
    "line",
    [
        "< frame 181 1.000000 010203040506070809 >",  # 9 data bytes
        "< frame 3FFFFFFFF 1.000000 01 >",  # 9 hex digits
        "< frame 20000000 1.000000 01 >",  # over 29 bits
        "< frame 800 1.000000 01 >",  # over 11 bits in 3 digits
        "< frame 1234 1.000000 01 >",  # 4 digits: neither form
        "< frame 181 nan 01 >",
        "< frame 181 inf 01 >",
    ],
)
def test_a_line_that_is_no_classic_can_frame_is_not_received(line: str) -> None:
    """What only a broken server sends is no frame (python-can's own parser took these); the
    frame after it is received."""
    import collections

    from drivers.socketcand_client import parse_frames

    out: collections.deque[can.Message] = collections.deque()
    assert parse_frames(line + "< frame 181 2.000000 0A >", "can0", out) == ""
    assert [(m.arbitration_id, bytes(m.data), m.timestamp) for m in out] == [(0x181, b"\x0a", 2.0)]
