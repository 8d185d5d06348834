"""``rig scan``: the CANopen nodes on a bus (or on an in-process emulator preset)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rig.cli.common import UsageError, add_bus_arguments, add_json, emulated, finite, open_network

__all__ = ["add_parser"]

MAX_LISTEN = 70.0  #: [s] heartbeats are at most 65.535 s apart (0x1017 is 16-bit milliseconds)
MAX_SDO_TIMEOUT = 60.0  #: [s]


def add_parser(sub: Any) -> None:
    """``rig scan``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    scan = sub.add_parser(
        "scan",
        help="list the CANopen nodes on a bus",
        description="Finds the nodes that answer an SDO upload of 0x1000 or send heartbeats, and lists "
        "node id, NMT state, device type, profile, vendor and product name.",
    )
    add_bus_arguments(scan)
    scan.add_argument(
        "--emulate",
        metavar="NAME",
        help="scan a preset or a zoo twin emulated in this process instead (rig emulate --list)",
    )
    scan.add_argument(
        "--listen",
        type=finite,
        default=1.1,
        help=f"seconds to listen for heartbeats (at most {MAX_LISTEN:g})",
    )
    scan.add_argument(
        "--sdo-timeout",
        type=finite,
        default=0.1,
        metavar="S",
        help=f"seconds to wait for each SDO answer (default 0.1; at most {MAX_SDO_TIMEOUT:g}): "
        "longer for a slow gateway or a loaded emulator",
    )
    add_json(scan, "print a list of JSON objects")
    scan.set_defaults(handler=run)


def _emulated(name: str, seconds: float, sdo_timeout: float) -> list[dict[str, Any]]:
    from plant_emulator.lockstep import LockstepBench
    from rig.commission.scan import scan

    kind, what = emulated(name, "rig scan")
    try:
        bench = LockstepBench(name) if kind == "preset" else LockstepBench(what.physics, device=what)
    except ValueError as exc:
        raise UsageError(f"rig scan: --emulate {name}: {exc}") from exc

    def listen() -> None:  # advance emulated time by ``seconds``
        for k in range(1, round(seconds / bench.period) + 1):
            for d in bench.devices:
                d.tick(k * bench.period)

    try:
        return scan(bench.host, listen=listen, sdo_timeout=sdo_timeout)
    finally:
        bench.close()


def _on_bus(args: argparse.Namespace) -> list[dict[str, Any]]:
    from rig.commission.scan import scan, wall_listen

    network = open_network(args, "rig scan")
    try:
        return scan(network, listen=wall_listen(args.listen), sdo_timeout=args.sdo_timeout)
    finally:
        network.disconnect()


#: the table's columns: (heading, JSON key)
COLUMNS = (
    ("node", "node_id"),
    ("NMT state", "nmt_state"),
    ("device type", "device_type"),
    ("profile", "profile"),
    ("vendor", "vendor_id"),
    ("vendor name", "vendor_name"),
    ("product", "product_name"),
)


def table(rows: list[dict[str, Any]]) -> list[str]:
    """The rows for a person: a column per field, '-' where it was not read, and a line per
    node with what could not be read (and why) after the table."""
    cells = [[h for h, _ in COLUMNS]]
    cells += [["-" if r.get(k) in (None, "") else str(r[k]) for _, k in COLUMNS] for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(COLUMNS))]
    lines = [
        "  ".join(c.rjust(w) if i == 0 else c.ljust(w) for i, (c, w) in enumerate(zip(cell, widths))).rstrip()
        for cell in cells
    ]
    lines += [f"node {r['node_id']}: {'; '.join(r['errors'])}" for r in rows if r.get("errors")]
    return lines


def run(args: argparse.Namespace) -> int:
    if not 0.0 < args.listen <= MAX_LISTEN:
        raise UsageError(
            f"rig scan: argument --listen: must be in (0, {MAX_LISTEN:g}] s, got {args.listen:g}"
        )
    if not 0.0 < args.sdo_timeout <= MAX_SDO_TIMEOUT:
        raise UsageError(
            f"rig scan: argument --sdo-timeout: must be in (0, {MAX_SDO_TIMEOUT:g}] s, "
            f"got {args.sdo_timeout:g}"
        )
    rows = _emulated(args.emulate, args.listen, args.sdo_timeout) if args.emulate else _on_bus(args)
    if args.json:
        print(json.dumps(rows))
        return 0
    print("\n".join(table(rows)))
    return 0
