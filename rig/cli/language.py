"""One command language for every ``rig`` command: one spelling per concept (``SPELLINGS``), the
old spellings kept one release as deprecated aliases (``Deprecated``, ``deprecated``), and a
command's options taken before or after its action (``inherit_options``). docs/cli.md shows the
table; tests/rig/test_cli_language.py walks every parser against it."""

from __future__ import annotations

import argparse
import copy
import sys
from collections.abc import Sequence
from typing import Any

__all__ = ["SPELLINGS", "SYNONYMS", "Deprecated", "MergingSubParsers", "deprecated", "inherit_options"]

#: concept -> (its one spelling, what it takes), the same on every command that has the concept
SPELLINGS = {
    "emulate in this process": (
        "--emulate NAME",
        "a preset (dc-servo, im-drive, grid-converter, dyno) or a zoo twin (rig emulate --list); rig run: "
        "NAME left out is the configuration's [emulator]",
    ),
    "node": ("--node N", "a CANopen node id"),
    "bus": ("--interface I --channel C [--bitrate B]", "python-can's interface and channel, bit/s"),
    "address": ("--host ADDRESS", "the address a client reaches or a server binds"),
    "port": ("--port P", "the TCP port a client reaches or a server serves on (0: any free one)"),
    "period": ("--period S", "a sample period T [s] (the configuration's [run] period)"),
    "figures": ("--plot DIR", "a folder, made if missing, before anything runs; the figures' names in it"),
    "JSON": ("--json", "one JSON document on stdout, nothing else there"),
    "parameter": ("--param NAME=VALUE", "a documented parameter by its name (repeatable)"),
}

#: the old spellings of a concept (``rig``'s, and the drive-check tests' options of
#: tests/conftest.py): refused on any parser unless they are a ``Deprecated`` alias (old
#: spelling -> the concept's spelling)
SYNONYMS = {
    "--dt": "--period",
    "--node-id": "--node",
    "--drive-node": "--node",
    "--socketcand-port": "--port",
    "--can-port": "--port",
    "--modbus-port": "--port",
    "--can-host": "--host",
    "--can-interface": "--interface",
    "--can-channel": "--channel",
}


class Deprecated(argparse.Action):
    """An old spelling kept for one release: it stores into the new spelling's ``dest`` and says
    once, on stderr, ``<command>: --old is deprecated: use --new``.

    Parameters
    ----------
    option_strings : Sequence[str]
        The old spelling(s).
    dest : str
        The new spelling's destination.
    new : str
        The new spelling, named in the warning.
    nargs : Any, optional
        argparse's; 0 (with ``const``) makes a switch.
    **kw : Any
        ``argparse.Action``'s other keywords.
    """

    def __init__(
        self, option_strings: Sequence[str], dest: str, *, new: str, nargs: Any = None, **kw: Any
    ) -> None:
        self.new = new
        super().__init__(option_strings, dest, nargs=nargs, **kw)

    def __call__(
        self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any, option: Any = None
    ) -> None:
        print(
            f"{parser.prog}: {option} is deprecated (kept for this release): use {self.new}", file=sys.stderr
        )
        setattr(namespace, self.dest, self.const if self.nargs == 0 else values)


def deprecated(parser: Any, old: str, new: str, dest: str, **kw: Any) -> None:
    """Add ``old`` to ``parser`` as a deprecated alias of ``new`` (``Deprecated``).

    Parameters
    ----------
    parser : Any
        The command's parser, or an argument group of it.
    old : str
        The old spelling.
    new : str
        The new spelling, named in the warning.
    dest : str
        The new spelling's destination.
    **kw : Any
        ``add_argument``'s keywords: the new option's ``type``, ``nargs``, ``metavar``.
    """
    kw.setdefault("help", f"deprecated: use {new} (kept for this release)")
    parser.add_argument(old, dest=dest, action=Deprecated, new=new, default=argparse.SUPPRESS, **kw)


class MergingSubParsers(argparse._SubParsersAction):  # type: ignore[type-arg]
    """argparse's subcommand action, but a repeatable option given both before and after the action
    (``rig drive --units a=1 status --units b=2``) keeps the values of both. ``Parser`` registers
    it; ``add_subparsers`` makes it, with argparse's own parameters.
    """

    def __call__(
        self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any, option: Any = None
    ) -> None:
        before = {k: v for k, v in vars(namespace).items() if isinstance(v, list)}
        super().__call__(parser, namespace, values, option)
        for key, old in before.items():
            new = getattr(namespace, key)
            if new is not old and isinstance(new, list) and old:
                setattr(namespace, key, [*old, *new])


def inherit_options(parser: argparse.ArgumentParser, skip: frozenset[str] = frozenset({"-h"})) -> None:
    """Every option of a command with actions (``rig drive``, ``rig drive sdo``) is taken after
    its action too (``rig drive status --json`` as ``rig drive --json status``), at any depth: a
    copy on each action's parser whose default is argparse.SUPPRESS, so the value given before the
    action stands unless given again after it. The copies are hidden from the action's help,
    whose epilog says so; an action's own option of the same name keeps its own meaning.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser, its actions added.
    skip : frozenset[str], optional
        Options not inherited.
    """
    _inherit(parser, [], skip)


def _inherit(parser: argparse.ArgumentParser, above: list[argparse.Action], skip: frozenset[str]) -> None:
    mine = [
        a
        for a in parser._actions
        if a.option_strings
        and not skip & set(a.option_strings)
        and not isinstance(a, argparse._SubParsersAction)
        and not getattr(a, "inherited", False)
    ]
    for action in parser._actions:
        if not isinstance(action, argparse._SubParsersAction):
            continue
        for name, child in action.choices.items():
            given = [
                a for a in [*above, *mine] if not set(a.option_strings) & set(child._option_string_actions)
            ]
            for a in given:
                twin = copy.copy(a)
                twin.default, twin.required, twin.help = argparse.SUPPRESS, False, argparse.SUPPRESS
                setattr(twin, "inherited", True)  # noqa: B010
                child._add_action(twin)
            if mine:
                note = f"The options of {parser.prog} are taken after {name!r} too ({parser.prog} --help)."
                child.epilog = f"{child.epilog} {note}" if child.epilog else note
            _inherit(child, given, skip)
