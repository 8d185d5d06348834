"""The ``rig-cli`` directive: the command-line reference, generated from rig's own argparse parsers.

It walks ``rig.cli.build_parser()`` and its subparsers, depth first, and gives each command a
section: its description, its usage line as argparse prints it, each argument (its option
strings or name, its metavar, choices, default and help) and its example (the epilog that
``--help`` ends with). Nothing is written by hand, so the reference cannot drift from the
parser; a command added to ``rig.cli.SUBCOMMANDS`` appears here by itself.
"""

from __future__ import annotations

import argparse
from typing import Any

from docutils import nodes
from sphinx.util.docutils import SphinxDirective

#: options every subcommand has (``-v`` after the subcommand, ``-h``): said once, on ``rig``
COMMON = {"-h", "-v"}


def _children(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """(name, one-line help, parser) of each subcommand of ``parser``."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            out += [(name, helps.get(name, ""), child) for name, child in action.choices.items()]
    return out


def _help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """The action's help with argparse's own %-expansions (``%(default)s``)."""
    if not action.help or action.help == argparse.SUPPRESS:
        return ""
    return parser._get_formatter()._expand_help(action)


def _names(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    formatter = parser._get_formatter()
    if not action.option_strings:
        return formatter._metavar_formatter(action, action.dest)(1)[0]
    if action.nargs == 0:
        return ", ".join(action.option_strings)
    metavar = formatter._format_args(action, action.dest.upper())
    return ", ".join(f"{o} {metavar}" for o in action.option_strings)


def _arguments(parser: argparse.ArgumentParser, top: bool) -> nodes.definition_list | None:
    items = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) or action.help == argparse.SUPPRESS:
            continue
        if not top and COMMON & set(action.option_strings):
            continue
        term = nodes.term("", "")
        term += nodes.literal(text=_names(parser, action))
        body = nodes.definition()
        text = _help(parser, action)
        extra = []
        if action.choices is not None and not isinstance(action.choices, dict):
            extra.append("one of " + ", ".join(map(str, action.choices)))
        if action.default not in (None, False, argparse.SUPPRESS, []) and action.option_strings:
            if "default" not in text:
                extra.append(f"default {action.default}")
        if action.required and action.option_strings:
            extra.append("required")
        body += nodes.paragraph(text=text + (f" ({'; '.join(extra)})" if extra else ""))
        items.append(nodes.definition_list_item("", term, body))
    if not items:
        return None
    listing = nodes.definition_list()
    listing.extend(items)
    return listing


class RigCli(SphinxDirective):
    """``rig-cli``: the sections of every ``rig`` command."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        from rig.cli import build_parser

        return [self._section(build_parser(), "rig", "", top=True)]

    def _section(self, parser: argparse.ArgumentParser, path: str, summary: str, top: bool) -> nodes.section:
        section = nodes.section(ids=[nodes.make_id(path)], names=[nodes.fully_normalize_name(path)])
        self.state.document.note_implicit_target(section)
        section += nodes.title(text=path)
        text = parser.description or summary
        if text:
            section += nodes.paragraph(text=text)
        usage = parser.format_usage().strip().removeprefix("usage: ")
        section += nodes.literal_block(usage, usage, language="text")
        arguments = _arguments(parser, top)
        if arguments is not None:
            section += arguments
        if parser.epilog:
            section += nodes.paragraph(text=parser.epilog)
        for name, one_line, child in _children(parser):
            section += self._section(child, f"{path} {name}", one_line, top=False)
        return section


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("rig-cli", RigCli)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
