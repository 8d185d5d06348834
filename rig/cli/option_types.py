"""argparse types of rig's options: a finite number, a TCP port, a file to write; each refuses
a bad value in one line naming it (``argparse.ArgumentTypeError``)."""

from __future__ import annotations

import argparse
import math
import pathlib

__all__ = ["finite", "out_file", "tcp_port", "tcp_port_or_any"]


def finite(text: str) -> float:
    """An argparse type: a finite number.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    float
        The number.

    Raises
    ------
    ArgumentTypeError
        If it is not a finite number.
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def tcp_port(text: str) -> int:
    """An argparse type: a TCP port 1..65535.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    int
        The port.
    """
    return _port(text, 1)


def tcp_port_or_any(text: str) -> int:
    """An argparse type: a TCP port to listen on, 0..65535 (0: any free port).

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    int
        The port.
    """
    return _port(text, 0)


def _port(text: str, low: int) -> int:
    try:
        port = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a port number: {text!r}") from None
    if not low <= port <= 65535:
        raise argparse.ArgumentTypeError(f"must be {low}..65535, got {port}")
    return port


def out_file(text: str) -> str:
    """An argparse type: a file to write (a plot): not a directory, in a folder that is there.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    str
        ``text``.

    Raises
    ------
    ArgumentTypeError
        If it is a directory, or its folder is missing.
    """
    path = pathlib.Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: a directory, not a file")
    if not path.resolve().parent.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: no folder {path.parent} to write it in")
    return text
