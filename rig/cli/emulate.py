"""``rig emulate``: the plant emulator as its own process (CANopen preset, or a Modbus inverter)."""

from __future__ import annotations

import argparse
from typing import Any

from rig.cli.common import UsageError, add_params, tcp_port, tcp_port_or_any
from rig.config.params import parse_items

__all__ = ["add_parser"]

_CAN_BITRATE = 1_000_000  #: [bit/s] classic CAN's highest bit rate (ISO 11898-1)


def add_parser(sub: Any) -> None:
    emulate = sub.add_parser(
        "emulate",
        help="run the plant emulator as its own process (a python-can bus, or socketcand on 127.0.0.1)",
        description="Serves an emulator preset on a python-can bus (--interface/--channel), or by default "
        "behind a socketcand rawmode server that python-can's socketcand interface reaches; or an "
        "emulated Modbus inverter (--modbus-map) on Modbus TCP or RTU. Ctrl-C or SIGTERM stops it.",
    )
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
    emulate.add_argument("--modbus-port", type=tcp_port, default=5020, help="Modbus TCP port (default 5020)")
    emulate.add_argument("--modbus-serial", metavar="DEVICE", help="serve Modbus RTU on this serial device")
    emulate.add_argument(
        "--listen",
        default="127.0.0.1",
        metavar="ADDRESS",
        help="address the TCP servers (socketcand, Modbus TCP) bind: 127.0.0.1 unless you name another",
    )
    emulate.add_argument(
        "--node-id", type=int, help="the drive's node id (the preset's others: the next); 255: none, LSS only"
    )
    emulate.add_argument(
        "--interface", help="python-can interface, e.g. socketcan (default: serve socketcand)"
    )
    emulate.add_argument("--channel", help="python-can channel, e.g. vcan0")
    emulate.add_argument(
        "--socketcand-port",
        type=tcp_port_or_any,
        default=29536,
        help="socketcand TCP port on --listen (0: any free port)",
    )
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
    add_params(emulate, "override a preset (or inverter) parameter")
    emulate.set_defaults(handler=run)


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
            f"rig emulate: --node-id {node_id}: must be 1..125 with --preset (its nodes are N, N+1, N+2)"
        )
    from drivers.schema import keys
    from plant_emulator.presets import PRESETS

    fields = keys(PRESETS[preset]) if preset in PRESETS else {}
    for offset, name in enumerate(("drive_node", "encoder_node", "load_node")):
        if name in fields:
            params[name] = str(node_id + offset)
    return params


def _list() -> int:
    from plant_emulator.device_profile import load_profile, zoo

    for name, path in zoo().items():
        print(f"{name:18} {load_profile(path).description}")
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
    if args.node_id is not None and not (1 <= args.node_id <= 127 or args.node_id == UNCONFIGURED):
        raise UsageError(f"rig emulate: --node-id {args.node_id}: must be 1..127 (or 255: none, LSS only)")
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
    _, params = physics(profile.physics, items, where, text=True, base=profile.params)
    od = load_od(profile.eds, args.node_id or profile.node_id)  # a bad EDS is refused before serving
    if args.node_id == UNCONFIGURED and not speaks_lss(od, profile.node_id):
        raise UsageError(
            f"rig emulate: --node-id 255 (no node-ID: LSS only): {profile.eds} says LSS_Supported=0, so that "
            "drive could never be given one; give it a node id 1..127"
        )
    # and so is a profile that disagrees with its EDS: built once on a network of its own
    build_twin(profile, canopen.Network(), params, node_id=args.node_id)

    def world(network: Any) -> Any:
        return build_twin(profile, network, params, node_id=args.node_id)

    node = (
        "no node-ID, LSS only" if args.node_id == UNCONFIGURED else f"node {args.node_id or profile.node_id}"
    )
    return world, f"{profile.name} ({node})"


def run(args: argparse.Namespace) -> int:
    from plant_emulator.presets import build_preset
    from rig.config.emulator import physics
    from rig.emulator.serve import run_emulator, run_modbus_emulator

    if args.list:
        return _list()
    if args.interface and not args.channel:
        raise UsageError("rig emulate: --interface needs --channel")
    if args.interface:
        from drivers.bus import check_interface

        check_interface(args.interface, "rig emulate: argument --interface")
    items = parse_items(args.param, "rig emulate: --param")
    if args.modbus_map:
        return run_modbus_emulator(
            args.modbus_map, items, host=args.listen, port=args.modbus_port, serial=args.modbus_serial
        )
    if sum(bool(x) for x in (args.preset, args.device, args.profile or args.eds)) != 1:
        raise UsageError(
            "rig emulate: give one of --preset, --device (or --profile/--eds) for CANopen, or --modbus-map"
        )
    if args.preset:
        from plant_emulator.presets import PRESETS

        if args.preset not in PRESETS:
            known = ", ".join(PRESETS)
            raise UsageError(f"rig emulate: --preset {args.preset}: unknown preset; known: {known}")
        items = _node_ids(args.preset, args.node_id, items)
        _, params = physics(args.preset, items, f"rig emulate: --preset {args.preset} --param", text=True)
        preset = args.preset

        def world(network: Any) -> Any:
            return build_preset(preset, network, params)

        label = preset
    else:
        world, label = _twin(args, items)
    return run_emulator(
        world,
        label,
        interface=args.interface,
        channel=args.channel,
        host=args.listen,
        port=args.socketcand_port,
        lockstep=args.time == "lockstep",
        realtime=_realtime(args),
        **({} if args.bitrate is None else {"bitrate": args.bitrate}),
    )


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
