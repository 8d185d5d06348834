"""``rig lss``: a drive's node-ID and bit rate over the bus (CiA 305, ``rig.commission.lss``)."""

from __future__ import annotations

import argparse
from typing import Any

from rig.cli.common import UsageError, add_bus_arguments, add_json, emulated, finite, open_network, print_json

__all__ = ["add_parser"]

_BOOT = 5.0  #: [s] a slave's boot-up with its new node-ID is awaited (a real bus)


def add_parser(sub: Any) -> None:
    """``rig lss``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    lss = sub.add_parser(
        "lss",
        help="set a drive's node-ID and bit rate over the bus (CiA 305 LSS): scan, inquire, node-id, "
        "bitrate, store",
        description="Layer setting services through canopen's LSS master: one slave is put in the LSS "
        "configuration state (--select its address, --fastscan the unconfigured one of lowest address, "
        "or, by default, every LSS slave: right with one drive on the bus only), the action runs, and "
        "every slave is switched back to waiting. A node-ID configured is the drive's at its next NMT "
        "reset communication (--reset sends it); a drive that had none (255) takes it then and boots "
        "with it. See docs/tutorial-commissioning.md.",
    )
    add_bus_arguments(lss)
    lss.add_argument(
        "--emulate",
        metavar="NAME",
        help="a zoo twin fresh from the box (no node-ID: 255) in this process instead (rig emulate --list)",
    )
    how = lss.add_mutually_exclusive_group()
    how.add_argument(
        "--select",
        metavar="ADDRESS",
        help="the slave of this LSS address only: VENDOR:PRODUCT:REVISION:SERIAL (its 0x1018; rig lss scan "
        "prints an unconfigured one's)",
    )
    how.add_argument(
        "--fastscan", action="store_true", help="the unconfigured slave of lowest address (found by fastscan)"
    )
    lss.add_argument(
        "--timeout", type=finite, default=0.5, help="how long each LSS answer is awaited [s] (default 0.5)"
    )
    lss.add_argument(
        "--stop",
        action="store_true",
        help="first send NMT stop to every node (maxon's EPOS4 answers LSS only in NMT STOPPED); they stay "
        "stopped, answering no SDO, until an NMT start or reset (node-id --reset resets the drive)",
    )
    add_json(lss, "print one JSON document")
    _add_actions(lss)
    lss.set_defaults(handler=run)


def _add_actions(lss: Any) -> None:
    """The actions of ``rig lss``."""
    actions = lss.add_subparsers(dest="action", required=True, parser_class=type(lss))
    actions.add_parser(
        "scan",
        help="how many drives without a node-ID answer, and the address of one (fastscan); changes nothing",
    )
    actions.add_parser("inquire", help="the slave's vendor, product, revision, serial (0x1018) and node-ID")
    node = actions.add_parser("node-id", help="configure the slave's node-ID")
    node.add_argument("node_id", type=int, metavar="N", help="1..127 (255: none)")
    bitrate = actions.add_parser("bitrate", help="configure the slave's bit rate (CiA 305's table)")
    bitrate.add_argument(
        "kbit", type=int, metavar="KBIT", help="1000, 800, 500, 250, 125, 50, 20 or 10 [kbit/s]"
    )
    bitrate.add_argument(
        "--activate",
        type=int,
        metavar="MS",
        help="then activate it: the slaves switch after MS ms (switch your interface too, then); they are "
        "left in the configuration state",
    )
    for action in (node, bitrate):
        action.add_argument("--store", action="store_true", help="and store it in the slave's memory")
    node.add_argument(
        "--reset",
        action="store_true",
        help="then NMT reset communication of the drive's node-ID now, so it takes the new one at once",
    )
    actions.add_parser("store", help="store the configuration (node-ID and bit rate) in the slave's memory")


def _check(args: argparse.Namespace) -> Any:
    """The checks before the bus opens; the address of --select, if any."""
    from rig.commission.lss import Address, bit_timing

    if not 0.0 < args.timeout <= 10.0:
        raise UsageError(f"rig lss: argument --timeout: must be in (0, 10] s, got {args.timeout:g}")
    if args.action == "node-id" and not (1 <= args.node_id <= 127 or args.node_id == 255):
        raise UsageError(f"rig lss node-id: {args.node_id}: a node-ID is 1..127 (or 255: none)")
    if args.action == "bitrate":
        try:
            bit_timing(args.kbit)
        except ValueError as exc:
            raise UsageError(f"rig lss bitrate: {exc}") from None
        if args.activate is not None and not 0 <= args.activate <= 0xFFFF:
            raise UsageError(f"rig lss bitrate: --activate {args.activate}: a switch delay is 0..65535 ms")
    if args.action == "scan" and (args.select or args.fastscan):
        raise UsageError("rig lss scan: it selects nobody (it finds an unconfigured drive's address)")
    try:
        return Address.parse(args.select) if args.select else None
    except ValueError as exc:
        raise UsageError(f"rig lss: argument --select: {exc}") from None


def _network(args: argparse.Namespace) -> tuple[Any, Any, float]:
    """(the host's network, a closer, the timeout [s] of an answer) on the bus or beside a twin."""
    if not args.emulate:
        network = open_network(args, "rig lss")
        return network, network.disconnect, args.timeout
    import dataclasses

    from drivers.maps.od import load_od
    from plant_emulator.lockstep import LockstepBench
    from plant_emulator.lss_slave import speaks_lss

    kind, profile = emulated(args.emulate, "rig lss")
    if kind == "preset":
        raise UsageError(
            f"rig lss --emulate {args.emulate}: a preset's drives have their node-IDs; give a zoo twin "
            "(rig emulate --list), served fresh from the box"
        )
    if not speaks_lss(load_od(profile.eds, profile.node_id), profile.node_id):
        raise UsageError(
            f"rig lss --emulate {args.emulate}: its EDS says LSS_Supported=0: that drive has no LSS"
        )
    bench = LockstepBench(profile.physics, device=dataclasses.replace(profile, node_id=255))
    return bench.host, bench.close, 0.01  # lock-step: an answer comes within the request's send


def _scan(tool: Any) -> dict[str, Any]:
    count = tool.unconfigured()
    if not count:
        return {"unconfigured": 0, "found": None, "select": None}
    found = tool.fastscan()
    node = tool.inquire()["node_id"]
    tool.leave()
    return {"unconfigured": count, "found": found.as_dict(), "node_id": node, "select": found.text()}


def _act(tool: Any, args: argparse.Namespace, address: Any) -> dict[str, Any]:
    if args.stop:
        tool.stop_all()
    if args.action == "scan":
        return _scan(tool)
    if address is not None:
        tool.select(address)
    elif args.fastscan:
        tool.fastscan()
    else:
        tool.all_slaves()
    out: dict[str, Any] = {"selected_by": tool.selected_by, **tool.inquire()}
    was = out["node_id"]
    if args.action == "node-id":
        tool.node_id(args.node_id)
        out |= {"node_id_was": was, "node_id": args.node_id}
    elif args.action == "bitrate":
        tool.bitrate(args.kbit)
        out["bitrate_kbit"] = args.kbit
    if args.action == "store" or getattr(args, "store", False):
        tool.store()
    out["stored"] = args.action == "store" or getattr(args, "store", False)
    if args.action == "bitrate" and args.activate is not None:
        tool.activate(args.activate)
        out["activated_after_ms"] = args.activate
        return out  # the slaves stay in the configuration state, switching their bit rate
    if args.action != "node-id" or args.node_id == was:
        tool.leave()
        return out
    booted = tool.boot_watch(args.node_id)
    tool.leave()  # one that had no node-ID takes the new one now
    if was != 255 and args.reset:
        tool.reset_communication(was)
    if was == 255 or args.reset:
        out["booted"] = booted.wait(_BOOT)
    else:
        out["booted"] = None  # pending until its next NMT reset communication
    return out


def _lines(out: dict[str, Any]) -> list[str]:
    """The text report."""
    if "unconfigured" in out:
        if not out["unconfigured"]:
            return ["unconfigured    none answered (no drive without a node-ID on this bus)"]
        return [
            f"unconfigured    {out['unconfigured']} answered (node-ID 255)",
            f"found           {out['select']} (the lowest address, by fastscan)",
            f"next            rig lss --select {out['select']} node-id N --store",
        ]
    lines = [f"selected by     {out['selected_by']}"]
    lines += [f"{k:15s} {out[k]}" for k in ("vendor", "product", "revision", "serial")]
    node = out["node_id"]
    if "node_id_was" in out:
        was = out["node_id_was"]
        lines.append(f"node-ID         {node} (was {'none, 255' if was == 255 else was})")
        if out["booted"] is True:
            lines.append(f"booted          as node {node}")
        elif out["booted"] is False:
            lines.append(f"booted          no boot-up of node {node} heard within {_BOOT:g} s")
        elif node != was:
            lines.append(
                "pending         the drive takes it at its next NMT reset communication (or --reset)"
            )
    else:
        lines.append(f"node-ID         {'none (255)' if node == 255 else node}")
    if "bitrate_kbit" in out:
        lines.append(f"bit rate        {out['bitrate_kbit']} kbit/s configured")
    if "activated_after_ms" in out:
        lines.append(
            f"activated       the slaves switch after {out['activated_after_ms']} ms: "
            "switch your interface too"
        )
    if out["stored"]:
        lines.append("stored          in the slave's non-volatile memory")
    return lines


def run(args: argparse.Namespace) -> int:
    from drivers.errors import CommunicationError, ConfigError
    from rig.commission.lss import LssTool

    address = _check(args)
    network, close, timeout = _network(args)
    try:
        out = _act(LssTool(network, timeout=timeout), args, address)
    except (CommunicationError, ConfigError) as exc:  # one line, naming the command
        raise type(exc)(f"rig lss {args.action}: {exc}") from exc
    finally:
        close()
    if args.json:
        print_json(out)
    else:
        print("\n".join(_lines(out)))
    return 0 if out.get("booted") is not False else 1
