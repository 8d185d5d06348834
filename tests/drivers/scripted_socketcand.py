"""The server's end of a socketcand connection, scripted by a test (a real TCP socket)."""

from __future__ import annotations

import socket

OPENED = (b"< ok >", b"< ok >")  #: the answers to ``< open CH >`` and ``< rawmode >``


def greet(link: socket.socket, answers: tuple[bytes, ...] = OPENED) -> None:
    """``< hi >``, then each of ``answers`` after a command from the client (one per command)."""
    link.sendall(b"< hi >")
    for answer in answers:
        link.recv(256)
        link.sendall(answer)
