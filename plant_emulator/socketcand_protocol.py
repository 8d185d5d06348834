"""socketcand's rawmode text protocol: bounded command framing, checked ``send``, ``frame`` lines.

A command is ASCII text ``< verb ... >``. ``CommandSplitter`` cuts a byte stream into
commands in time linear in the input and refuses a command longer than ``MAX_COMMAND``
bytes. ``checked_command`` checks the others (``open``, ``rawmode``, ``echo``) against the client's
state. ``parse_send`` accepts a frame only when every field is valid (as socketcand's
README has it): a standard id of 3 hex digits 000..7FF or an extended one of 8 hex digits
00000000..1FFFFFFF, a DLC 0..8 equal to the number of data bytes, each byte one or two
hex digits. ``format_frame`` writes ``< frame ID SEC.USEC HEXDATA >`` as socketcand does
(and python-can's socketcand client reads): the timestamp is wall-clock seconds.
"""

from __future__ import annotations

import re
from collections.abc import Iterator

import can

__all__ = [
    "BUS_NAME",
    "MAX_COMMAND",
    "CommandSplitter",
    "CommandTooLong",
    "ProtocolError",
    "checked_command",
    "checked_send",
    "command_words",
    "format_frame",
    "parse_send",
    "shown",
]

#: [bytes] the longest command, ``<`` to ``>``; a client that sends more without ``>`` is dropped
MAX_COMMAND = 4096
BUS_NAME = 16  #: the longest bus name socketcand takes

_STANDARD_ID = re.compile(r"[0-9A-Fa-f]{3}")
_EXTENDED_ID = re.compile(r"[0-9A-Fa-f]{8}")
_DLC = re.compile(r"[0-9]{1,2}")
_BYTE = re.compile(r"[0-9A-Fa-f]{1,2}")
STANDARD_MAX = 0x7FF
EXTENDED_MAX = 0x1FFFFFFF
#: a valid ``send`` in one match (the common case, every frame of every cycle); anything else
#: goes through the field-by-field checks that name what is wrong
_VALID_SEND = re.compile(
    r"\s*<\s*send\s+([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})\s+([0-8])((?:\s+[0-9A-Fa-f]{1,2})*)\s*>?\s*"
)


class ProtocolError(ValueError):
    """A command the server refuses; its text goes to the client as ``< error TEXT >``."""


class CommandTooLong(ProtocolError):
    """More than ``MAX_COMMAND`` bytes without ``>``: the client is dropped."""


def shown(text: str, limit: int = 24) -> str:
    """``text`` quoted for an error line: ASCII, no ``<``/``>``, at most ``limit`` characters.

    Parameters
    ----------
    text : str
        What a client sent.
    limit : int, optional
        The most characters shown.

    Returns
    -------
    str
        ``text``, quoted.
    """
    cut = text[:limit]
    quoted = ascii(cut).replace("<", "\\x3c").replace(">", "\\x3e")
    return quoted + ("..." if len(text) > limit else "")


class CommandSplitter:
    """Cut a byte stream into commands; what is held between chunks stays below ``limit`` bytes.

    Each chunk is scanned once, together with at most ``limit`` bytes held from before,
    so the work is linear in the input however it is chunked.

    Parameters
    ----------
    limit : int, optional
        [bytes] held between chunks at most.
    """

    def __init__(self, limit: int = MAX_COMMAND) -> None:
        self.limit = limit
        self._held = b""

    def feed(self, chunk: bytes) -> Iterator[str]:
        """The commands completed by ``chunk``, each stripped text up to and without ``>``.

        Raises ``CommandTooLong`` (after yielding the commands before it) when a command
        exceeds ``limit`` bytes, ``>`` included, or the text held without ``>`` does.

        Parameters
        ----------
        chunk : bytes
            Bytes received.

        Yields
        ------
        Iterator[str]
            Each command completed, stripped, without its ``>``.

        Raises
        ------
        CommandTooLong
            If a command grows beyond ``limit`` (after those before it).
        """
        *complete, rest = (self._held + chunk).split(b">")
        self._held = b""
        for raw in complete:
            if len(raw) >= self.limit:
                raise CommandTooLong(f"command of {len(raw) + 1} bytes (at most {self.limit})")
            yield raw.decode("ascii", errors="replace").strip()
        if len(rest) >= self.limit:
            raise CommandTooLong(f"{len(rest)} bytes without '>' (a command is at most {self.limit})")
        self._held = rest


def command_words(text: str) -> list[str]:
    """The words of one command (``< ... >``, the ``>`` may be cut off already); ProtocolError if none.

    Parameters
    ----------
    text : str
        One command.

    Returns
    -------
    list[str]
        Its words.

    Raises
    ------
    ProtocolError
        If it has none.
    """
    text = text.strip()
    if not text.startswith("<"):
        raise ProtocolError(f"a command starts with '<', not {shown(text)}")
    words = text[1:].removesuffix(">").split()
    if not words:
        raise ProtocolError("empty command '< >'")
    return words


def checked_command(text: str, *, opened: bool, rawmode: bool) -> str:
    """The verb of a command but ``send``, checked against the client's state: ``< open BUS >``
    once, with one bus name of up to ``BUS_NAME`` characters; ``< rawmode >`` once, after it;
    ``< echo >`` at any time.

    Parameters
    ----------
    text : str
        The command, ``<`` to ``>``.
    opened : bool
        The client has opened a bus.
    rawmode : bool
        The client is in rawmode.

    Returns
    -------
    str
        "open", "rawmode" or "echo".

    Raises
    ------
    ProtocolError
        If the command is unknown, malformed or out of turn.
    """
    words = command_words(text)
    verb = words[0]
    if verb == "open":
        if opened:
            raise ProtocolError("a bus is open already")
        if len(words) != 2 or len(words[1]) > BUS_NAME:
            name = " ".join(words[1:])
            raise ProtocolError(f"open takes one bus name of up to {BUS_NAME} characters: {shown(name)}")
    elif verb == "rawmode":
        if not opened:
            raise ProtocolError("rawmode before '< open BUS >'")
        if rawmode:
            raise ProtocolError("rawmode already")
    elif verb != "echo":
        raise ProtocolError(f"unknown command {shown(verb)}")
    return verb


def _parse_id(word: str) -> tuple[int, bool]:
    """CAN id field -> (id, extended)."""
    if _STANDARD_ID.fullmatch(word):
        can_id, extended, top = int(word, 16), False, STANDARD_MAX
    elif _EXTENDED_ID.fullmatch(word):
        can_id, extended, top = int(word, 16), True, EXTENDED_MAX
    else:
        raise ProtocolError(f"CAN id {shown(word)}: not 3 (standard) or 8 (extended) hex digits")
    if can_id > top:
        kind = "extended" if extended else "standard"
        raise ProtocolError(f"CAN id {shown(word)}: over {top:X}, the largest {kind} id")
    return can_id, extended


def parse_send(text: str) -> can.Message:
    """``< send ID DLC B0 ... >`` -> Message; ProtocolError naming the field that is wrong.

    Parameters
    ----------
    text : str
        A ``send`` command.

    Returns
    -------
    can.Message
        The frame.
    """
    match = _VALID_SEND.fullmatch(text)
    if match is not None:
        ident, dlc_text, data_text = match.groups()
        data_words = data_text.split()
        can_id, extended = int(ident, 16), len(ident) == 8
        if len(data_words) == int(dlc_text) and can_id <= (EXTENDED_MAX if extended else STANDARD_MAX):
            data = bytes([int(word, 16) for word in data_words])
            return can.Message(arbitration_id=can_id, is_extended_id=extended, data=data, dlc=len(data))
    return checked_send(text)


def checked_send(text: str) -> can.Message:
    """``parse_send`` field by field: the path of a command that is not a plain valid ``send``.

    Parameters
    ----------
    text : str
        A ``send`` command.

    Returns
    -------
    can.Message
        The frame.

    Raises
    ------
    ProtocolError
        Naming the field that is wrong.
    """
    words = command_words(text)
    if words[0] != "send":
        raise ProtocolError(f"not a send command: {shown(text)}")
    if len(words) < 3:
        raise ProtocolError(f"send needs an id and a DLC: {shown(text)}")
    can_id, extended = _parse_id(words[1])
    if not _DLC.fullmatch(words[2]) or int(words[2]) > 8:
        raise ProtocolError(f"DLC {shown(words[2])}: not 0..8")
    dlc, data_words = int(words[2]), words[3:]
    if len(data_words) != dlc:
        raise ProtocolError(f"DLC {dlc} but {len(data_words)} data bytes")
    for word in data_words:
        if not _BYTE.fullmatch(word):
            raise ProtocolError(f"data byte {shown(word)}: not 00..FF")
    data = bytes(int(word, 16) for word in data_words)
    return can.Message(arbitration_id=can_id, is_extended_id=extended, data=data, dlc=dlc)


def format_frame(msg: can.Message, stamp: float) -> str:
    """``msg`` as ``< frame ID SEC.USEC HEXDATA >``, stamped ``stamp`` [s, wall clock].

    Parameters
    ----------
    msg : can.Message
        The frame.
    stamp : float
        [s] wall clock.

    Returns
    -------
    str
        The line.
    """
    can_id = f"{msg.arbitration_id:08X}" if msg.is_extended_id else f"{msg.arbitration_id:03X}"
    return f"< frame {can_id} {stamp:.6f} {bytes(msg.data).hex().upper()} >"
