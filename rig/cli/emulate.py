"""``rig emulate``: the plant emulator as its own process (CANopen preset, or a Modbus inverter)."""

from __future__ import annotations

import argparse
from typing import Any

from rig.cli.common import UsageError, add_params
from rig.params import parse_items

__all__ = ["add_parser"]


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
        "--modbus-map",
        metavar="NAME",
        help="serve an emulated Modbus inverter of this map instead (abb-drives-profile, delta-vfd-b)",
    )
    emulate.add_argument("--modbus-port", type=int, default=5020, help="Modbus TCP port (default 5020)")
    emulate.add_argument("--modbus-serial", metavar="DEVICE", help="serve Modbus RTU on this serial device")
    emulate.add_argument(
        "--listen",
        default="127.0.0.1",
        metavar="ADDRESS",
        help="address the TCP servers (socketcand, Modbus TCP) bind: 127.0.0.1 unless you name another",
    )
    emulate.add_argument(
        "--node-id", type=int, help="node id of the drive (the other nodes of the preset take the next ones)"
    )
    emulate.add_argument(
        "--interface", help="python-can interface, e.g. socketcan (default: serve socketcand)"
    )
    emulate.add_argument("--channel", help="python-can channel, e.g. vcan0")
    emulate.add_argument(
        "--socketcand-port",
        type=int,
        default=29536,
        help="socketcand TCP port on --listen (0: any free port)",
    )
    emulate.add_argument(
        "--time",
        choices=("realtime", "lockstep"),
        default="realtime",
        help="lockstep: an event RPDO counts as received at its SYNC (for hosts that wait for each answer)",
    )
    add_params(emulate, "override a preset (or inverter) parameter")
    emulate.set_defaults(handler=run)


def _node_ids(preset: str, node_id: int | None, params: dict[str, str]) -> dict[str, str]:
    if node_id is None:
        return params
    if not 1 <= node_id <= 125:
        raise UsageError(f"rig emulate: --node-id {node_id}: must be 1..125")
    from plant_emulator.presets import PRESETS
    from rig.params import field_types

    fields = field_types(PRESETS[preset]) if preset in PRESETS else {}
    for offset, name in enumerate(("drive_node", "encoder_node", "load_node")):
        if name in fields:
            params[name] = str(node_id + offset)
    return params


def run(args: argparse.Namespace) -> int:
    from rig.emulate import run_emulator, run_modbus_emulator
    from rig.host.emulation import preset_params

    if args.interface and not args.channel:
        raise UsageError("rig emulate: --interface needs --channel")
    items = parse_items(args.param, "rig emulate: --param")
    if args.modbus_map:
        return run_modbus_emulator(
            args.modbus_map, items, host=args.listen, port=args.modbus_port, serial=args.modbus_serial
        )
    if not args.preset:
        raise UsageError("rig emulate: give --preset (CANopen) or --modbus-map (Modbus)")
    items = _node_ids(args.preset, args.node_id, items)
    params = preset_params(args.preset, items, f"rig emulate: --preset {args.preset} --param")
    return run_emulator(
        args.preset,
        params,
        interface=args.interface,
        channel=args.channel,
        host=args.listen,
        port=args.socketcand_port,
        lockstep=args.time == "lockstep",
    )
