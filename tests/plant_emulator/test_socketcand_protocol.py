"""socketcand's rawmode text, without sockets: the checks of ``send``, the bounded command
framing, and agreement with python-can's own socketcand client on both directions."""

from __future__ import annotations

import can
import pytest
from can.interfaces.socketcand import socketcand as client
from hypothesis import given, settings
from hypothesis import strategies as st

from plant_emulator.socketcand_protocol import (
    MAX_COMMAND,
    CommandSplitter,
    CommandTooLong,
    ProtocolError,
    checked_send,
    format_frame,
    parse_send,
)

CASES = settings(max_examples=200, deadline=None)


@pytest.mark.parametrize(
    ("command", "named"),
    [
        ("< send -1 0 >", "'-1'"),
        ("< send 200000000 0 >", "'200000000'"),  # 2**33: nine digits
        ("< send 800 0 >", "'800'"),  # three digits: standard, over 7FF
        ("< send 20000000 0 >", "'20000000'"),  # eight digits: extended, over 1FFFFFFF
        ("< send 12 0 >", "'12'"),
        ("< send 0x1 0 >", "'0x1'"),
        ("< send 123 9 1 2 3 4 5 6 7 8 9 >", "'9'"),
        ("< send 123 -1 >", "'-1'"),
        ("< send 123 F >", "'F'"),
        ("< send 123 2 AA >", "DLC 2 but 1 data bytes"),
        ("< send 123 1 AA BB >", "DLC 1 but 2 data bytes"),
        ("< send 123 1 100 >", "'100'"),
        ("< send 123 1 -1 >", "'-1'"),
        ("< send 123 1 G1 >", "'G1'"),
        ("< send 123 >", "an id and a DLC"),
        ("send 123 0 >", "starts with '<'"),
    ],
)
def test_a_bad_send_is_refused_naming_the_field(command: str, named: str) -> None:
    with pytest.raises(ProtocolError) as info:
        parse_send(command)
    assert named in str(info.value)
    assert "<" not in str(info.value).replace("'<'", "") and ">" not in str(info.value)


@pytest.mark.parametrize(
    ("command", "can_id", "extended", "data"),
    [
        ("< send 000 0", 0, False, b""),
        ("< send 7FF 8 0 1 2 3 4 5 6 ff", 0x7FF, False, bytes([0, 1, 2, 3, 4, 5, 6, 255])),
        ("< send 00000000 1 aA", 0, True, b"\xaa"),
        ("< send 1FFFFFFF 2 1 F1", 0x1FFFFFFF, True, b"\x01\xf1"),
    ],
)
def test_the_limits_are_accepted(command: str, can_id: int, extended: bool, data: bytes) -> None:
    msg = parse_send(command)
    assert (msg.arbitration_id, msg.is_extended_id, bytes(msg.data), msg.dlc) == (
        can_id,
        extended,
        data,
        len(data),
    )


@CASES
@given(st.text(max_size=80))
def test_any_text_is_a_frame_in_range_or_a_protocol_error(text: str) -> None:
    try:
        msg = parse_send("< send " + text)
    except ProtocolError:
        return
    top = 0x1FFFFFFF if msg.is_extended_id else 0x7FF
    assert 0 <= msg.arbitration_id <= top and msg.dlc == len(msg.data) <= 8


def _outcome(parse: object, text: str) -> object:
    try:
        msg = parse(text)  # type: ignore[operator]
    except ProtocolError as exc:
        return str(exc)
    return (msg.arbitration_id, msg.is_extended_id, bytes(msg.data), msg.dlc)


@CASES
@given(
    st.one_of(
        st.text(max_size=60),
        st.builds(
            lambda i, n, bs, sp: f"<{sp}send {i} {n}{''.join(sp + ' ' + b for b in bs)}{sp}",
            st.sampled_from(["000", "7FF", "800", "1FFFFFFF", "20000000", "12", "0x1", "abc"]),
            st.sampled_from(["0", "1", "2", "8", "9", "08", "-1"]),
            st.lists(st.sampled_from(["0", "ff", "1F", "100", "G1", "-1"]), max_size=9),
            st.sampled_from(["", " ", "\t"]),
        ),
    )
)
def test_the_one_match_path_and_the_field_by_field_path_agree(text: str) -> None:
    """``parse_send`` takes a plain valid ``send`` in one regular expression; on any text it
    gives what the field-by-field checks give (the frame, or the same refusal)."""
    assert _outcome(parse_send, text) == _outcome(checked_send, text)


@CASES
@given(
    st.integers(0, 0x1FFFFFFF),
    st.booleans(),
    st.binary(max_size=8),
    st.floats(0, 4e9, allow_nan=False),
)
def test_python_can_reads_what_it_sends_through_the_server(
    can_id: int, extended: bool, data: bytes, stamp: float
) -> None:
    """python-can's ``send`` text parses to its message; our ``frame`` text parses back to it."""
    can_id &= 0x1FFFFFFF if extended else 0x7FF
    sent = can.Message(arbitration_id=can_id, is_extended_id=extended, data=data)
    msg = parse_send(client.convert_can_message_to_ascii_message(sent))
    assert (msg.arbitration_id, msg.is_extended_id, bytes(msg.data)) == (can_id, extended, data)
    back = client.convert_ascii_message_to_can_message(format_frame(msg, stamp))
    assert (back.arbitration_id, back.is_extended_id, bytes(back.data)) == (can_id, extended, data)
    assert back.timestamp == pytest.approx(stamp, abs=1e-6)


PIECES = ["< echo >", "< send 123 1 AA >", " ", "\n", "< x >"]


@CASES
@given(st.lists(st.sampled_from(PIECES), max_size=30), st.data())
def test_commands_are_the_same_however_the_stream_is_cut(parts: list[str], data: st.DataObject) -> None:
    stream = "".join(parts).encode()
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=10)))
    splitter, got = CommandSplitter(), list[str]()
    for start, end in zip([0, *cuts], [*cuts, len(stream)]):
        got.extend(splitter.feed(stream[start:end]))
    assert got == [p.strip() for p in "".join(parts).split(">")[:-1]]


def test_a_command_is_at_most_max_command_bytes() -> None:
    splitter = CommandSplitter()
    assert list(splitter.feed(b"<" + b" " * (MAX_COMMAND - 2) + b">")) == ["<"]
    with pytest.raises(CommandTooLong, match="4097 bytes"):
        list(splitter.feed(b"<" + b" " * (MAX_COMMAND - 1) + b">"))


def test_text_without_end_is_refused_at_max_command_bytes_however_it_comes() -> None:
    """Held text never grows past the limit: 1-byte chunks fail at the 4096th byte."""
    splitter = CommandSplitter()
    for _ in range(MAX_COMMAND - 1):
        assert list(splitter.feed(b"A")) == []
    with pytest.raises(CommandTooLong, match="4096 bytes without '>'"):
        list(splitter.feed(b"A"))


def test_commands_before_an_overlong_one_are_still_served() -> None:
    splitter = CommandSplitter()
    got = []
    with pytest.raises(CommandTooLong):
        for text in splitter.feed(b"< echo >< rawmode >" + b"A" * 70000):
            got.append(text)
    assert got == ["< echo", "< rawmode"]
