"""What a socketcand client's commands do (``plant_emulator.socketcand_server``).

``< open CH >`` is answered ``< ok >`` (any bus name will do: there is one bus), ``< rawmode >``
is the server's (it sends every frame from then on), any other verb is echoed. A command refused
(``checked_command``: a bad id, DLC or byte, a second ``< rawmode >``, an unknown verb) is
answered ``< error WHAT >`` and reaches nobody. A ``< send ... >`` becomes the client's frame
waiting for the bus, ranked as CAN arbitration ranks it (``arbitration``) and, among equal
ranks, by the order frames came to wait.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import can

from plant_emulator.socketcand_link import ClientLink
from plant_emulator.socketcand_protocol import ProtocolError, checked_command, parse_send

__all__ = ["ClientCommands", "arbitration"]

log = logging.getLogger(__name__)


def arbitration(msg: can.Message) -> int:
    """The frame's rank in CAN arbitration (lower wins): the 11-bit base identifier first, then
    a standard frame before an extended one of that base (its IDE bit is dominant), then the
    18-bit extension (ISO 11898-1).

    Parameters
    ----------
    msg : can.Message
        The frame.

    Returns
    -------
    int
        Its rank.
    """
    if msg.is_extended_id:
        return ((msg.arbitration_id >> 18) << 19) | (1 << 18) | (msg.arbitration_id & 0x3FFFF)
    return msg.arbitration_id << 19


class ClientCommands:
    """The commands of the server's clients, done on its I/O thread; see the module docstring.

    Parameters
    ----------
    reply : Callable[[ClientLink, str], None]
        Queues a line to a client.
    rawmode : Callable[[ClientLink], None]
        Puts a client in rawmode (``< ok >``, then every frame).
    """

    def __init__(
        self, reply: Callable[[ClientLink, str], None], rawmode: Callable[[ClientLink], None]
    ) -> None:
        self.reply = reply
        self.rawmode = rawmode
        self._tickets = 0  #: frames that came to wait for the bus so far (their order)

    def advance(self, client: ClientLink) -> bool:
        """``client``'s commands that need no bus, up to its first frame (``client.head``, ranked
        by ``client.head_key``).

        Parameters
        ----------
        client : ClientLink
            The client.

        Returns
        -------
        bool
            True when a frame of it waits for the bus.
        """
        while client.commands and not client.crowded and client.doomed is None:
            if client.head is not None:
                return True
            text = client.commands[0]
            if not text.lstrip("< \t\r\n").startswith("send"):
                client.commands.popleft()
                self.command(client, text)
                continue
            try:
                msg = parse_send(text)  # checked before the bus is opened: the error names the field
                if not client.opened:
                    raise ProtocolError("send before '< open BUS >'")
            except ProtocolError as exc:
                client.commands.popleft()
                self.refuse(client, exc)
                continue
            self._tickets += 1
            client.head, client.head_key = msg, (arbitration(msg), self._tickets)
            return True
        return False

    def command(self, client: ClientLink, text: str) -> None:
        """Do one command but ``send`` (``advance``; checked by ``checked_command``); a refused one
        is answered.

        Parameters
        ----------
        client : ClientLink
            The client that sent it.
        text : str
            The command.
        """
        try:
            verb = checked_command(text, opened=client.opened, rawmode=client.rawmode)
        except ProtocolError as exc:
            self.refuse(client, exc)
            return
        if verb == "open":  # any bus name will do (there is one bus)
            self.reply(client, "< ok >")
            client.opened = True
        elif verb == "rawmode":
            self.rawmode(client)
        else:
            self.reply(client, "< echo >")

    def refuse(self, client: ClientLink, exc: ProtocolError) -> None:
        """``< error ... >`` to ``client`` (its first refusal logged).

        Parameters
        ----------
        client : ClientLink
            The client.
        exc : ProtocolError
            What was wrong.
        """
        client.errors += 1
        level = logging.WARNING if client.errors == 1 else logging.DEBUG
        log.log(level, "socketcand: client %s: %s (%d refused so far)", client.name, exc, client.errors)
        self.reply(client, f"< error {exc} >")
