"""The options that open a CAN bus (``--interface``, ``--channel``, ``--bitrate``, socketcand's
``--host`` and ``--port``) and the canopen network they open."""

from __future__ import annotations

import argparse
from typing import Any

from drivers.errors import ConfigError
from rig.cli.option_types import tcp_port
from rig.cli.usage import UsageError

__all__ = ["add_bus_arguments", "open_network"]


def add_bus_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that open a CAN bus (python-can interface and channel, socketcand address).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    group = parser.add_argument_group("CAN bus")
    group.add_argument("--interface", help="python-can interface (e.g. socketcan, socketcand, pcan)")
    group.add_argument("--channel", help="python-can channel (e.g. vcan0, can0)")
    group.add_argument(
        "--bitrate", type=int, help="bit rate [bit/s] where the interface sets it (e.g. 500000)"
    )
    group.add_argument("--host", default="127.0.0.1", help="socketcand host (default 127.0.0.1)")
    group.add_argument("--port", type=tcp_port, default=29536, help="socketcand port (default 29536)")


def open_network(args: argparse.Namespace, who: str) -> Any:
    """A connected canopen network on the bus of ``add_bus_arguments``' options.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.
    who : str
        The command, named in errors.

    Returns
    -------
    Any
        The canopen network, connected.

    Raises
    ------
    UsageError
        If the options name no bus, or a bit rate not > 0, or it cannot open.
    """
    import canopen

    from drivers.bus import check_interface, open_bus

    if not (args.interface and (args.channel or args.interface == "socketcand")):
        raise UsageError(f"{who}: give --interface and --channel, or --emulate NAME")
    try:
        check_interface(args.interface, f"{who}: argument --interface")
    except ConfigError as exc:
        raise UsageError(str(exc)) from None
    if args.bitrate is not None and args.bitrate <= 0:
        raise UsageError(f"{who}: argument --bitrate: must be > 0 bit/s, got {args.bitrate}")
    extra = {"host": args.host, "port": args.port} if args.interface == "socketcand" else {}
    network = canopen.Network(open_bus(args.interface, args.channel or "can0", bitrate=args.bitrate, **extra))
    network.NOTIFIER_CYCLE = (
        0.1  # [s] the receive thread's wait: closing takes at most that, not canopen's 1 s
    )
    network.connect()
    return network
