"""``rig emulate``: the plant emulator as its own process (CANopen preset, or a Modbus inverter)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

from rig.cli.common import (
    UsageError,
    add_json,
    add_params,
    finite,
    print_json,
    tcp_port,
    tcp_port_or_any,
)
from rig.cli.language import deprecated
from rig.config.params import parse_items

__all__ = ["add_parser", "run"]

_CAN_BITRATE = 1_000_000  #: [bit/s] classic CAN's highest bit rate (ISO 11898-1)
SOCKETCAND_PORT = 29536  #: socketcand's own default port
MODBUS_PORT = 5020  #: the Modbus TCP port by default (502 needs root)


def add_parser(sub: Any) -> None:
    """``rig emulate``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    emulate = sub.add_parser(
        "emulate",
        help="run the plant emulator as its own process (a python-can bus, or socketcand on 127.0.0.1)",
        description="Serves an emulator preset on a python-can bus (--interface/--channel), or by default "
        "behind a socketcand rawmode server that python-can's socketcand interface reaches; or an "
        "emulated Modbus inverter (--modbus-map) on Modbus TCP or RTU. Ctrl-C or SIGTERM stops it.",
    )
    _add_device(emulate)
    _add_network(emulate)
    _add_realtime(emulate)
    emulate.add_argument(
        "--period",
        type=finite,
        metavar="S",
        help="the emulated plant's sample period T [s] (its parameter period; default: the preset's or "
        "twin's)",
    )
    add_params(emulate, "override a preset (or inverter) parameter")
    add_json(emulate, "with --list: print the list as one JSON document")
    emulate.set_defaults(handler=run)


def _add_device(emulate: Any) -> None:
    """What is emulated: a preset, a zoo twin, your own profile, or a Modbus inverter."""
    emulate.add_argument("--preset", help="dc-servo, im-drive, grid-converter or dyno (CANopen)")
    emulate.add_argument(
        "--device",
        metavar="PROFILE",
        help="serve the virtual twin of a drive: a profile of the zoo (see --list) or a profile file (.toml)",
    )
    emulate.add_argument(
        "--profile", metavar="FILE", help="your drive's device profile (TOML; see docs/emulator.md)"
    )
    emulate.add_argument("--eds", metavar="FILE", help="your drive's EDS/DCF (with --profile, or alone)")
    emulate.add_argument("--list", action="store_true", help="list the zoo's device profiles and exit")
    emulate.add_argument(
        "--modbus-map",
        metavar="NAME",
        help="serve an emulated Modbus inverter of this map instead (abb-drives-profile, delta-vfd-b)",
    )
    emulate.add_argument("--modbus-serial", metavar="DEVICE", help="serve Modbus RTU on this serial device")


def _add_network(emulate: Any) -> None:
    """Where it serves: the TCP server's address and port, or a python-can bus; its node id and time."""
    emulate.add_argument(
        "--host",
        default="127.0.0.1",
        metavar="ADDRESS",
        help="address the TCP server (socketcand, or Modbus TCP) binds: 127.0.0.1 unless you name another",
    )
    deprecated(emulate, "--listen", "--host", "host", metavar="ADDRESS")
    emulate.add_argument(
        "--port",
        type=tcp_port_or_any,
        metavar="P",
        help=f"the TCP port it serves on, on --host (default: socketcand {SOCKETCAND_PORT}, Modbus TCP "
        f"{MODBUS_PORT}; 0: any free port)",
    )
    deprecated(emulate, "--socketcand-port", "--port", "port", type=tcp_port_or_any, metavar="P")
    deprecated(emulate, "--modbus-port", "--port", "port", type=tcp_port, metavar="P")
    emulate.add_argument(
        "--node",
        type=int,
        metavar="N",
        help="node id of the drive (the other nodes of the preset take the next ones); 255: none, LSS only",
    )
    deprecated(emulate, "--node-id", "--node", "node", type=int, metavar="N")
    emulate.add_argument(
        "--interface", help="python-can interface, e.g. socketcan (default: serve socketcand)"
    )
    emulate.add_argument("--channel", help="python-can channel, e.g. vcan0")
    emulate.add_argument(
        "--bitrate",
        type=_bitrate,
        help="bit rate [bit/s] of the socketcand server's bus: a client that sends faster is held back "
        "to it, as on a real bus (default 1000000)",
    )
    emulate.add_argument(
        "--time",
        choices=("realtime", "lockstep"),
        default="realtime",
        help="lockstep: an event RPDO counts as received at its SYNC (for hosts that wait for each answer)",
    )


def _add_realtime(emulate: Any) -> None:
    """The options of a real-time emulator's scheduling (``_realtime``)."""
    emulate.add_argument(
        "--rt-priority",
        type=int,
        default=49,
        metavar="N",
        help="real time: SCHED_FIFO priority of the emulator's clock and of the threads carrying its "
        "frames (1-99; 0: normal scheduling; default 49, below a host loop's 50)",
    )
    emulate.add_argument(
        "--rt-cpu",
        type=int,
        default=0,
        metavar="N",
        help="real time: the CPU they are pinned to (default 0; -1: the last CPU; -2: not pinned)",
    )
    emulate.add_argument(
        "--rt-lock-memory",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="real time: lock the emulator's memory (default: yes)",
    )
    emulate.add_argument(
        "--rt-cpu-latency",
        type=int,
        default=0,
        metavar="US",
        help="real time: the PM QoS CPU latency [us] held while it serves (/dev/cpu_dma_latency; "
        "default 0: the CPUs stay awake; -1: none asked)",
    )


def _bitrate(text: str) -> int:
    """An argparse type: a bit rate of 1 bit/s .. 1 Mbit/s (classic CAN's range)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number of bit/s: {text!r}") from None
    if not 0 < value <= _CAN_BITRATE:
        raise argparse.ArgumentTypeError(f"{value} bit/s: classic CAN runs at 1 .. 1000000 bit/s")
    return value


def _node_ids(preset: str, node_id: int | None, params: dict[str, str]) -> dict[str, str]:
    if node_id is None:
        return params
    if not 1 <= node_id <= 125:
        raise UsageError(
            f"rig emulate: --node {node_id}: must be 1..125 with --preset (its nodes are N, N+1, N+2)"
        )
    from drivers.schema import keys
    from plant_emulator.presets import PRESETS

    fields = keys(PRESETS[preset]) if preset in PRESETS else {}
    for offset, name in enumerate(("drive_node", "encoder_node", "load_node")):
        if name in fields:
            params[name] = str(node_id + offset)
    return params


def _period(args: argparse.Namespace, items: dict[str, str]) -> dict[str, str]:
    """``items`` with ``--period``'s value as the parameter period; ``--param period=`` is the old
    spelling, kept for this release with one line on stderr."""
    if "period" in items:
        if args.period is not None:
            raise UsageError("rig emulate: --period and --param period= name one value: give --period")
        print(
            "rig emulate: --param period= is deprecated (kept for this release): use --period",
            file=sys.stderr,
        )
    elif args.period is not None:
        if not args.period > 0.0:
            raise UsageError(f"rig emulate: argument --period: must be > 0 s, got {args.period:g}")
        items["period"] = repr(args.period)
    return items


def _checked(args: argparse.Namespace, check: Callable[[], Any]) -> Any:
    """``check()``, its refusal of the period named as --period where that gave it."""
    from drivers.errors import ConfigError

    try:
        return check()
    except ConfigError as exc:
        if args.period is None:
            raise
        raise ConfigError(str(exc).replace("--param period = ", "--period ")) from None


def _list(json: bool) -> int:
    from plant_emulator.device_profile import load_profile, zoo

    rows = [{"name": name, "description": load_profile(path).description} for name, path in zoo().items()]
    if json:
        print_json(rows)
        return 0
    for row in rows:
        print(f"{row['name']:18} {row['description']}")
    return 0


def _twin(args: argparse.Namespace, items: dict[str, str]) -> tuple[Any, str]:
    """The world of ``--device`` or ``--profile``/``--eds``: (builder, label)."""
    import dataclasses
    import pathlib

    import canopen

    from drivers.errors import ConfigError
    from drivers.maps.lss import UNCONFIGURED
    from drivers.maps.od import load_od
    from plant_emulator.device_profile import default_profile, device_profile, load_profile
    from plant_emulator.lss_slave import speaks_lss
    from plant_emulator.presets import build_twin
    from rig.config.emulator import physics

    if args.device and (args.profile or args.eds):
        raise UsageError("rig emulate: --device takes a zoo profile; for your own drive give --profile/--eds")
    if args.node is not None and not (1 <= args.node <= 127 or args.node == UNCONFIGURED):
        raise UsageError(f"rig emulate: --node {args.node}: must be 1..127 (or 255: none, LSS only)")
    if args.device:
        try:
            profile = device_profile(args.device)
        except ConfigError as exc:
            raise UsageError(f"rig emulate: --device {args.device}: {exc}") from None
    elif args.profile:
        profile = load_profile(pathlib.Path(args.profile))
        if args.eds:
            profile = dataclasses.replace(profile, eds=pathlib.Path(args.eds).resolve())
    else:
        profile = default_profile(pathlib.Path(args.eds))
    where = f"rig emulate: --device {profile.name} --param"
    _, params = _checked(args, lambda: physics(profile.physics, items, where, text=True, base=profile.params))
    od = load_od(profile.eds, args.node or profile.node_id)  # a bad EDS is refused before serving
    if args.node == UNCONFIGURED and not speaks_lss(od, profile.node_id):
        raise UsageError(
            f"rig emulate: --node 255 (no node-ID: LSS only): {profile.eds} says LSS_Supported=0, so that "
            "drive could never be given one; give it a node id 1..127"
        )
    # and so is a profile that disagrees with its EDS: built once on a network of its own
    build_twin(profile, canopen.Network(), params, node_id=args.node)

    def world(network: Any) -> Any:
        return build_twin(profile, network, params, node_id=args.node)

    node = "no node-ID, LSS only" if args.node == UNCONFIGURED else f"node {args.node or profile.node_id}"
    return world, f"{profile.name} ({node})"


def run(args: argparse.Namespace) -> int:
    """Run ``rig emulate``: the list, or the emulator served until Ctrl-C or SIGTERM.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Returns
    -------
    int
        The exit code.

    Raises
    ------
    UsageError
        If the options do not name one thing to serve, or one is out of range.
    """
    from rig.emulator.serve import run_emulator, run_modbus_emulator

    if args.list:
        return _list(args.json)
    _check_options(args)
    items = _period(args, parse_items(args.param, "rig emulate: --param"))
    if args.modbus_map:
        port = MODBUS_PORT if args.port is None else args.port
        if port == 0:
            raise UsageError("rig emulate: argument --port: Modbus TCP needs a port 1..65535, got 0")
        return run_modbus_emulator(
            args.modbus_map, items, host=args.host, port=port, serial=args.modbus_serial
        )
    world, label = _world(args, items)
    return run_emulator(
        world,
        label,
        interface=args.interface,
        channel=args.channel,
        host=args.host,
        port=SOCKETCAND_PORT if args.port is None else args.port,
        lockstep=args.time == "lockstep",
        realtime=_realtime(args),
        **({} if args.bitrate is None else {"bitrate": args.bitrate}),
    )


def _check_options(args: argparse.Namespace) -> None:
    """--json only with --list; --interface with --channel, and one python-can knows."""
    if args.json:
        raise UsageError(
            "rig emulate: --json goes with --list: a server prints where it serves (on stdout), not a result"
        )
    if args.interface and not args.channel:
        raise UsageError("rig emulate: --interface needs --channel")
    if args.interface:
        from drivers.bus import check_interface

        check_interface(args.interface, "rig emulate: argument --interface")


def _world(args: argparse.Namespace, items: dict[str, str]) -> tuple[Any, str]:
    """(the CANopen world to serve on a network, its label): a preset's, or a twin's (``_twin``)."""
    from plant_emulator.presets import PRESETS, build_preset
    from rig.config.emulator import physics

    if sum(bool(x) for x in (args.preset, args.device, args.profile or args.eds)) != 1:
        raise UsageError(
            "rig emulate: give one of --preset, --device (or --profile/--eds) for CANopen, or --modbus-map"
        )
    if not args.preset:
        return _twin(args, items)
    if args.preset not in PRESETS:
        known = ", ".join(PRESETS)
        raise UsageError(f"rig emulate: --preset {args.preset}: unknown preset; known: {known}")
    items = _node_ids(args.preset, args.node, items)
    where = f"rig emulate: --preset {args.preset} --param"
    _, params = _checked(args, lambda: physics(args.preset, items, where, text=True))
    preset = args.preset

    def world(network: Any) -> Any:
        return build_preset(preset, network, params)

    return world, preset


def _realtime(args: argparse.Namespace) -> Any:
    from rig.host.realtime import RealtimeRequest

    if not 0 <= args.rt_priority <= 99:
        raise UsageError(
            f"rig emulate: --rt-priority {args.rt_priority}: must be 0-99 (0: normal scheduling)"
        )
    if args.rt_cpu < -2:
        raise UsageError(
            f"rig emulate: --rt-cpu {args.rt_cpu}: a CPU number, -1 (the last) or -2 (not pinned)"
        )
    if args.rt_cpu_latency < -1:
        raise UsageError(
            f"rig emulate: --rt-cpu-latency {args.rt_cpu_latency}: microseconds >= 0, or -1 (none asked)"
        )
    return RealtimeRequest(args.rt_priority, args.rt_cpu, args.rt_lock_memory, args.rt_cpu_latency)
