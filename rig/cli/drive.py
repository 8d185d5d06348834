"""``rig drive``: commission one CiA 402 node on any bus (``rig.commission.drive``)."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from drivers.errors import NodeSilent, RigError
from drivers.maps.logical import MAX_AXES, axis_object
from rig.cli import drive_dictionary
from rig.cli.common import (
    EXIT_STOPPED,
    EXIT_UNCONFIRMED,
    UsageError,
    add_bus_arguments,
    add_json,
    add_params,
    finite,
    open_network,
    print_json,
)
from rig.cli.run import LIVE_MODES, open_view
from rig.commission.status import object_lines, status_lines

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """``rig drive``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    drive = sub.add_parser(
        "drive",
        help="commission one CiA 402 drive: status, enable/disable/reset, SDO, jog, home, move",
        description="Talks to one CiA 402 node by SDO: its status (identity, state and every statusword bit, "
        "mode, actual values, limits, ramps, windows, errors, inputs, units and PDO mapping in force), its "
        "state machine, its objects by index[:sub] or EDS name, and short moves on its own profile modes. A "
        "move ends, as Ctrl-C or SIGTERM does, with the drive's quick stop ramp to rest and then disable. "
        "Exit code 3 when a move was stopped, 4 when the stop was not confirmed, 130 or 143 (and no result) "
        "after Ctrl-C or SIGTERM.",
    )
    _add_drive(drive)
    actions = drive.add_subparsers(dest="action", required=True, parser_class=type(drive))
    actions.add_parser("status", help="what the drive is and how it is set up")
    actions.add_parser("enable", help="operational and OPERATION ENABLED (no motion is commanded)")
    actions.add_parser("disable", help="disable voltage")
    actions.add_parser("reset", help="fault reset (rising edge of controlword bit 7)")
    sdo = actions.add_parser("sdo", help="read or write one object")
    ops = sdo.add_subparsers(dest="op", required=True, parser_class=type(drive))
    ops.add_parser("read").add_argument("object", help="index[:sub] (0x6060, 0x1018:1) or EDS name")
    write = ops.add_parser("write")
    write.add_argument("object", help="index[:sub] or EDS name")
    write.add_argument("value", help="an integer (0x.. allowed) or a number")
    _add_moves(actions)
    drive_dictionary.add_actions(actions)
    drive.set_defaults(handler=run)


def _add_drive(drive: Any) -> None:
    """Which drive: its bus, node, axis, dictionary and units, or a twin in this process; --json."""
    add_bus_arguments(drive)
    drive.add_argument("--node", type=int, default=1, help="the drive's node id (default 1)")
    drive.add_argument(
        "--axis",
        type=int,
        default=1,
        help="which axis of a drive of several on the node (default 1; axis N's objects are 0x800 (N - 1) "
        "above axis 1's: an object named here, as in sdo, is axis N's)",
    )
    drive.add_argument("--eds", metavar="FILE", help="the drive's EDS/DCF (default: the toolkit's)")
    drive.add_argument(
        "--emulate", metavar="NAME", help="a zoo twin (rig emulate --list) or a preset, in this process"
    )
    add_params(drive, "a unit the drive lacks, as [axis.units] (counts_per_rev=51200)", flag="--units")
    add_json(drive, "print one JSON document")


def _add_moves(actions: Any) -> None:
    """The actions that move the shaft: jog, home, move, and the options they share."""
    jog = actions.add_parser("jog", help="profile velocity for a while")
    jog.add_argument("speed", type=finite, help="[rad/s]")
    jog.add_argument("--for", dest="seconds", type=finite, required=True, help="[s]")
    home = actions.add_parser("home", help="homing")
    home.add_argument("--method", type=int, help="0x6098 homing method (default: the drive's)")
    move = _add_move(actions)
    for action in (jog, move):
        action.add_argument(
            "--accel", type=finite, metavar="RAD_S2", help="acceleration [rad/s^2] (0x6083/0x6084)"
        )
        action.add_argument(
            "--limit", type=finite, help="deprecated: --max-speed on jog, --max-travel on move"
        )
    for action in (jog, home, move):
        action.add_argument(
            "--max-speed",
            type=finite,
            default=20.0,
            metavar="RAD_S",
            help="the fastest the shaft may turn [rad/s] (20): faster is a stop",
        )
        action.add_argument(
            "--live",
            nargs="?",
            const="auto",
            choices=LIVE_MODES,
            metavar="{terminal,window}",
            help="show the target, the actual value (read by SDO at each look) and the command (the "
            "target the drive's own profile follows) as they arrive, in a window or as a strip on "
            "stderr (as rig run --live); e.g. rig drive --emulate epos4 jog 10 --for 1 --live=terminal",
        )


def _add_move(actions: Any) -> Any:
    """``rig drive move``'s parser: to a position, at a speed, holding it or not."""
    move = actions.add_parser("move", help="profile position to a position")
    move.add_argument("position", type=finite, help="[rad], absolute (or, with --relative, from here)")
    move.add_argument("--relative", action="store_true", help="the position is a travel from where it stands")
    move.add_argument(
        "--speed",
        type=finite,
        metavar="RAD_S",
        help="the move's speed [rad/s] (0x6081; default: the drive's)",
    )
    move.add_argument(
        "--max-travel", type=finite, default=10.0, metavar="RAD", help="the farthest a move may go [rad] (10)"
    )
    move.add_argument(
        "--hold",
        type=finite,
        nargs="?",
        const=math.inf,
        metavar="S",
        help="stay enabled holding the target that long [s] (no value: until Ctrl-C, at most an hour), "
        "then the stop",
    )
    return move


def _check(args: argparse.Namespace) -> None:
    if not 1 <= args.node <= 127:
        raise UsageError(f"rig drive: argument --node: must be 1..127, got {args.node}")
    if not 1 <= args.axis <= MAX_AXES:
        raise UsageError(f"rig drive: argument --axis: must be 1..{MAX_AXES}, got {args.axis}")
    if args.action == "jog" and not 0.0 < args.seconds <= 60.0:
        raise UsageError(f"rig drive jog: argument --for: must be in (0, 60] s, got {args.seconds:g}")
    if args.action == "home" and args.method is not None and not -128 <= args.method <= 127:
        raise UsageError(f"rig drive home: argument --method: must be -128..127, got {args.method}")
    if args.action in ("jog", "move") and args.limit is not None:
        if not args.limit > 0.0:
            raise UsageError(f"rig drive {args.action}: argument --limit: must be > 0, got {args.limit:g}")
        new = "--max-speed" if args.action == "jog" else "--max-travel"
        print(f"rig drive {args.action}: --limit is deprecated: use {new}", file=sys.stderr)
        setattr(args, "max_speed" if args.action == "jog" else "max_travel", args.limit)
    for key in ("max_speed", "max_travel", "speed", "accel", "hold"):
        value = getattr(args, key, None)
        if value is not None and not value > 0.0:
            name = "--" + key.replace("_", "-")
            raise UsageError(f"rig drive {args.action}: argument {name}: must be > 0, got {value:g}")
    if args.action == "sdo" and args.op == "write":
        _value(args.value)
    drive_dictionary.check(args)


def _tool(args: argparse.Namespace) -> tuple[Any, Any]:
    """(the DriveTool, a closer) on the bus or on an in-process twin."""
    from drivers.cia402 import Cia402Axis
    from drivers.maps import CIA402_EDS
    from drivers.maps.cia402_needs import CONTROL, STATUS, require
    from drivers.maps.logical import axis_dictionary
    from drivers.maps.od import load_od
    from drivers.master_watch import MasterWatch
    from rig.cli.common import params_of
    from rig.commission.drive import DriveTool, parse_object
    from rig.config import AxisUnits

    units = {k: float(v) for k, v in params_of(args.units, AxisUnits, "rig drive: --units").items()}
    for key, value in units.items():
        if not value >= 0.0:
            raise UsageError(f"rig drive: --units {key} = {value:g}: must be >= 0 (0: the drive's own)")
    profile, preset = None, None
    if args.emulate:
        from rig.cli.common import emulated

        kind, what = emulated(args.emulate, "rig drive")
        profile, preset = (what, None) if kind == "device" else (None, what)
    eds = args.eds or (str(profile.eds) if profile else None)  # None: the device's own units, modes
    od = load_od(eds or CIA402_EDS, args.node)  # a bad EDS, an axis it lacks, an object it does not name
    od = axis_dictionary(od, args.axis, source=str(eds or CIA402_EDS), generic=eds is None)
    if args.action == "sdo":
        parse_object(args.object, od)
    elif args.action not in drive_dictionary.ACTIONS:  # and one that lacks what the action needs to
        # read the drive's state or move it (its mode's objects: DriveTool, once the drive says it
        # offers the mode)
        needs = STATUS if args.action == "status" else CONTROL
        require(od, needs, source=str(eds), what=f"rig drive {args.action}")
    if args.emulate:
        from plant_emulator.lockstep import LockstepBench

        bench = (
            LockstepBench(str(preset)) if profile is None else LockstepBench(profile.physics, device=profile)
        )
        network, idle, period, close = bench.host, bench.sync, bench.period, bench.close
        watch = None
    else:
        network = open_network(args, "rig drive")
        idle, period, close = None, 0.01, network.disconnect
        watch = MasterWatch(network, [args.node])  # heard from the bus's opening on
    axis = Cia402Axis("drive", network, args.node, mode="csp", eds=eds, units=units, axis=args.axis)

    def done() -> None:
        axis.abandon()  # the tool leaves the drive as its command left it (enable: enabled)
        if watch is not None:
            watch.close()
        close()

    return DriveTool(axis, idle=idle, period=period, watch=watch), done


def _value(text: str) -> int | float:
    try:
        return int(text, 0)
    except ValueError:
        try:
            value = float(text)
        except ValueError:
            raise UsageError(f"rig drive sdo write: value {text!r} is not a number") from None
    if not math.isfinite(value):
        raise UsageError(f"rig drive sdo write: value {text!r} is not a finite number")
    return value


def _bus_hint(args: argparse.Namespace) -> str:
    """The ``rig scan`` line for the bus of ``args`` (or the twin's, with --emulate)."""
    from drivers.bus import scan_command

    if args.emulate:
        return f"the twin {args.emulate} is node 1; on a bus, rig scan --interface I --channel C"
    return scan_command(args.interface, args.channel or "", args.bitrate, args.host, args.port)


def _act(tool: Any, args: argparse.Namespace) -> Any:
    from drivers.canopen_axis import CanopenAxis
    from drivers.cia402_pdo import variable
    from rig.commission.drive import parse_object

    a = tool.axis
    if args.action == "status":
        return tool.status()
    if args.action in drive_dictionary.ACTIONS:
        return drive_dictionary.act(tool, args)
    if args.action in ("enable", "disable", "reset"):
        return {"state": getattr(tool, args.action)()}
    if args.action == "sdo":
        index, sub = parse_object(args.object, a.node.object_dictionary)
        where = f"0x{axis_object(index, args.axis):04X}:{sub:02X}"  # the object on the wire: axis N's
        if args.op == "read":
            return tool.read_object(index, sub)
        var = variable(a.node.object_dictionary, (index, sub))
        if var is not None and not var.writable:
            raise UsageError(
                f"rig drive sdo write: {where} ({var.name}) is {var.access_type} in the EDS: nothing was sent"
            )
        a.discover(check_mode=False)  # the device the EDS describes, before the write
        try:  # what the operator names is the task: a manufacturer object too (not Cia402Axis's guard)
            if var is None and not a.discovery.standard_write(
                index, sub, _value(args.value)
            ):  # by CiA 402's type
                own = "" if a.eds_given else "; give the drive's own EDS (--eds FILE)"
                raise UsageError(f"rig drive sdo write: {where} is not in {a.eds}: nothing was sent{own}")
            if var is not None:
                CanopenAxis.sdo_write(a, index, sub, _value(args.value))
        except (OverflowError, ValueError, TypeError, AttributeError) as exc:  # canopen's encoding
            if isinstance(exc, RigError):
                raise
            raise UsageError(
                f"rig drive sdo write: value {args.value!r} does not fit the type of 0x{index:04X}:{sub:02X}"
                f" ({exc})"
            ) from None
        return {"object": where, "written": _value(args.value)}
    from rig.commission import moves

    if args.action == "jog":
        return moves.jog(tool, args.speed, args.seconds, max_speed=args.max_speed, accel=args.accel)
    if args.action == "home":
        return moves.home(tool, args.method, max_speed=args.max_speed)
    return moves.move(
        tool,
        args.position,
        relative=args.relative,
        speed=args.speed,
        accel=args.accel,
        max_speed=args.max_speed,
        max_travel=args.max_travel,
        hold=args.hold,
    )


def _watch(live: Any, args: argparse.Namespace, tool: Any) -> None:
    """Start ``live`` on the drive's looks: the target, the actual value, the target again."""
    from rig.live import Channel

    unit = "rad/s" if args.action == "jog" else "rad"
    what = "velocity" if args.action == "jog" else "position"
    tool.live = live.rows
    live.start([Channel(f"node {args.node}", 1, 2, 3, what, (unit, unit, unit))], f"drive {args.action}")


def run(args: argparse.Namespace) -> int:
    """Run ``rig drive ACTION`` on the drive and print its result.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Returns
    -------
    int
        The exit code: 0; 3 when a move was stopped; 4 when the stop was not confirmed.

    Raises
    ------
    NodeSilent
        If the node does not answer (with the ``rig scan`` command that lists those that do).
    """
    _check(args)
    live = open_view(getattr(args, "live", None), "rig drive")  # a window that cannot open: before the bus
    try:
        tool, close = _tool(args)
        try:
            if live is not None:
                _watch(live, args, tool)
            result = _act(tool, args)
        except NodeSilent as exc:
            hint = _bus_hint(args)
            said = f"{hint}" if args.emulate else f"`{hint}` lists the nodes that answer"
            raise NodeSilent(f"{exc}; {said}") from exc
        finally:
            close()
    finally:
        if live is not None:
            live.stop()
    _print(args, result, tool)
    if isinstance(result, dict) and result.get("stop_confirmed") is False:
        print("rig drive: the drive's stop was not confirmed", file=sys.stderr)
        return EXIT_UNCONFIRMED
    if isinstance(result, dict) and str(result.get("result", "done")) != "done":
        return EXIT_STOPPED
    return 0


def _print(args: argparse.Namespace, result: Any, tool: Any) -> None:
    """The action's result on stdout: one JSON document, or a report for a person."""
    if args.json:
        print_json(result)
    elif args.action == "status":
        print("\n".join(status_lines(result, tool.object_name)))
    elif args.action in drive_dictionary.ACTIONS:
        print("\n".join(drive_dictionary.result_lines(result)))
    elif args.action in ("jog", "move", "home"):
        from rig.commission.move_report import report_lines

        units = tool.axis.units
        print("\n".join(report_lines(args.action, result, units.position, units.velocity)))
    elif args.action == "sdo" and args.op == "read":
        print("\n".join(object_lines(result)))
    else:
        for key, value in result.items():
            print(f"{key:16s} {value}")
