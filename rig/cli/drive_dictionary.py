"""``rig drive dump`` (``rig.commission.dictionary``, ``rig.commission.dcf``), ``store`` and
``restore`` (``rig.commission.store``): the actions on a drive's whole dictionary, registered on
``rig drive``'s parser by ``add_actions``.

A store or a restore asks the person at the terminal first (on stderr; ``y`` or ``yes``
confirms); ``--yes`` confirms for a script. Without a terminal, or with ``--json`` (a program
reads stdout), it is refused before the bus opens unless ``--yes`` is given.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from rig.cli.common import UsageError, out_file

__all__ = ["ACTIONS", "act", "add_actions", "check", "result_lines"]

ACTIONS = ("dump", "store", "restore")  #: the actions of this module


def add_actions(actions: Any) -> None:
    """The actions on ``rig drive``'s sub-parsers ``actions``.

    Parameters
    ----------
    actions : Any
        ``rig drive``'s sub-parsers.
    """
    dump = actions.add_parser(
        "dump",
        help="every object of the drive's dictionary with its value now, read by SDO (text, --json, --dcf)",
        description="Reads every object the EDS/DCF in use names (without the drive's own EDS: the "
        "standard objects only) and lists each with its value in hex and decimal, type, access and "
        "unit (and in SI where the drive's factors are known); an object the drive refuses is listed "
        "with the abort in words. Writes nothing to the drive.",
    )
    dump.add_argument(
        "--dcf",
        metavar="FILE",
        type=out_file,
        help="also write a DCF (CiA 306): the drive's EDS with each value read as ParameterValue and "
        "its node id and bit rate in [DeviceComissioning] (needs the drive's own EDS, --eds)",
    )
    store = actions.add_parser(
        "store",
        help="store the drive's parameters in its non-volatile memory (0x1010:01 'save'), once confirmed",
        description="Writes the signature 'save' to 0x1010:01 (CiA 301): the drive keeps the parameters "
        "it holds now over a power cycle. Asks first, naming the drive.",
    )
    restore = actions.add_parser(
        "restore",
        help="restore the drive's default parameters (0x1011:01 'load'), once confirmed",
        description="Writes the signature 'load' to 0x1011:01 (CiA 301): the drive's defaults replace "
        "its stored parameters at its next reset (power cycle, or --reset). Asks first, naming the drive.",
    )
    restore.add_argument(
        "--reset",
        action="store_true",
        help="then reset the drive (NMT reset node) and wait for its boot-up, so the defaults are in force "
        "(refused while it is enabled)",
    )
    for action in (store, restore):
        action.add_argument("--yes", action="store_true", help="do not ask (a script's confirmation)")


def check(args: argparse.Namespace) -> None:
    """UsageError, before the bus opens, for a store or restore nobody can confirm.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Raises
    ------
    UsageError
        If a store or restore cannot be confirmed (``--json`` or no terminal, without ``--yes``).
    """
    if args.action not in ("store", "restore") or args.yes:
        return
    if args.json:
        raise UsageError(f"rig drive {args.action}: --json without --yes: a program confirms with --yes")
    if not sys.stdin.isatty():
        raise UsageError(
            f"rig drive {args.action}: no terminal to confirm on: give --yes to {args.action} without asking"
        )


def _confirm(args: argparse.Namespace) -> Any:
    """The confirmation of ``args``: --yes, or the person's answer at the terminal."""

    def ask(question: str) -> bool:
        if args.yes:
            return True
        print(f"{question} [y/N] ", end="", file=sys.stderr, flush=True)
        return sys.stdin.readline().strip().lower() in ("y", "yes")

    return ask


def act(tool: Any, args: argparse.Namespace) -> dict[str, Any]:
    """Run action ``args.action`` with ``tool`` (a ``rig.commission.drive.DriveTool``).

    Parameters
    ----------
    tool : Any
        The drive.
    args : argparse.Namespace
        The parsed options.

    Returns
    -------
    dict[str, Any]
        The action's result.
    """
    if args.action == "dump":
        return _dump(tool, args)
    from rig.commission.store import store

    restore = args.action == "restore"
    return store(tool, restore=restore, confirm=_confirm(args), reset=restore and args.reset)


def _dump(tool: Any, args: argparse.Namespace) -> dict[str, Any]:
    from drivers.maps.od import eds_text
    from rig.commission.dcf import dcf_text
    from rig.commission.dictionary import read_dictionary

    a = tool.axis
    a.discover(check_mode=False)  # the device against its EDS (identity), and its units
    own = bool(a.eds_given or a.toolkit_drive)  # the dictionary in use is the device's own
    if args.dcf and not own:
        raise ConfigError(
            f"rig drive dump --dcf: node {a.node_id} is {a.device_id.text()}, and the dictionary in use "
            f"is the toolkit's generic one: a DCF is the drive's own EDS with its values; give it (--eds "
            "FILE); nothing was read"
        )
    entries = read_dictionary(a, standard_only=not own)
    result: dict[str, Any] = {
        "node": a.node_id,
        "identity": a.device_id.text(),
        "eds": a.eds,
        "standard_only": not own,
        "read": sum(e.refused is None for e in entries),
        "not_read": sum(e.refused is not None for e in entries),
        "objects": [e.as_dict() for e in entries],
        "dcf": None,
    }
    if args.dcf:
        names = [e.value for e in entries if (e.index, e.subindex) == (0x1008, 0) and e.refused is None]
        info = getattr(a.node.object_dictionary, "device_information", None)
        text = dcf_text(
            eds_text(a.eds),
            entries,
            eds_path=a.eds,
            dcf_path=args.dcf,
            node_id=a.node_id,
            node_name=str(names[0] if names else getattr(info, "product_name", "") or ""),
            bitrate=getattr(args, "bitrate", None) if not args.emulate else None,
            serial=a.device_id.serial,
        )
        try:
            Path(args.dcf).write_text(text, encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"rig drive dump --dcf {args.dcf}: not written: {exc.strerror}") from None
        result["dcf"] = args.dcf
    return result


def result_lines(result: dict[str, Any]) -> list[str]:
    """The text report of an action's ``result``.

    Parameters
    ----------
    result : dict[str, Any]
        An action's result.

    Returns
    -------
    list[str]
        The lines.
    """
    from rig.commission import store
    from rig.commission.dictionary import dump_lines

    if "written" in result:
        return store.result_lines(result)

    heading = f"node {result['node']}: {result['identity']} (dictionary {result['eds']})"
    if result["standard_only"]:
        heading += (
            "\nthe standard objects only (0x1000-0x1FFF, 0x6000-0x9FFF): the dictionary in use is not "
            "the drive's own; give its EDS (--eds FILE) for the manufacturer objects"
        )
    lines = dump_lines(result["objects"], heading)
    if result["dcf"]:
        lines += ["", f"DCF written to {result['dcf']}"]
    return lines
