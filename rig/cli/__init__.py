"""The ``rig`` command line: ``main(argv=None) -> int``; one module per subcommand.

Each subcommand module has ``add_parser(sub)``, which adds its parser and sets
its handler with ``set_defaults(handler=...)``. Only this module configures
logging. Exit codes: 0 done, 1 a failure of the rig (communication, device),
2 a bad argument or configuration, 3 a safety stop, 4 a stop the drives did not
confirm (they may still be moving), 5 ``rig identify --strict`` warned, 130 interrupted,
141 the reader of stdout left (``rig ... | head``). ``-v`` goes before or after the
subcommand.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from drivers.errors import ConfigError, RigError
from rig.cli import (
    bench,
    demo,
    design,
    doctor,
    drive,
    emulate,
    export,
    faults,
    identify,
    reproduce,
    run,
    scan,
    sweep,
    tune,
)
from rig.cli.common import EXIT_USAGE, Parser, UsageError

__all__ = ["main"]

SUBCOMMANDS = (
    demo,
    design,
    tune,
    reproduce,
    run,
    identify,
    scan,
    drive,
    emulate,
    faults,
    sweep,
    bench,
    doctor,
    export,
)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("drive-rig")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


class _Version(argparse.Action):
    """``--version``: the installed version, read (importlib.metadata) only when asked for."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kw: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, help="show the version and exit", **kw)

    def __call__(self, parser: argparse.ArgumentParser, *args: Any) -> NoReturn:
        print(f"rig {_version()}")
        parser.exit()


FORMAT = "%(levelname)s %(name)s: %(message)s"


class BriefFormatter(logging.Formatter):
    """One line per record: an exception's type and words instead of its traceback (``rig -v``
    shows tracebacks), whichever library logged it."""

    def format(self, record: logging.LogRecord) -> str:
        text = record.getMessage().split("Traceback (most recent call last)")[0].rstrip()
        brief = logging.makeLogRecord({**record.__dict__, "msg": text, "args": (), "exc_info": None})
        if record.exc_info and record.exc_info[1] is not None:
            exc = record.exc_info[1]
            return f"{super().format(brief)}: {type(exc).__name__}: {exc}"
        return super().format(brief)


def build_parser() -> Parser:
    parser = Parser(prog="rig", description="drive-rig: electrical-drive lab rig toolkit.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages to stderr")
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for module in SUBCOMMANDS:
        module.add_parser(sub)
    _verbose_everywhere(parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                if name in EXAMPLES:
                    child.epilog = f"Example: {EXAMPLES[name]}"
    return parser


#: the example each subcommand's --help ends with (commands the docs pages run too)
EXAMPLES = {
    "demo": "rig demo",
    "design": "rig design dtsm --a-m 16 --b-m 680 --dt 0.4e-3 --lam -15 --error-space --json",
    "reproduce": "rig reproduce dismc --json",
    "run": "rig run --config examples/dc_servo_position.toml --emulate",
    "identify": "rig identify --emulate dc-servo --param plant.a_m=23.5 --param plant.b_m=412",
    "tune": "rig tune pi-speed --from-identify runs/identify-voltage-DATE-TIME --bandwidth 20 --json",
    "scan": "rig scan --emulate dc-servo   (a real bus: rig scan --interface socketcan --channel can0)",
    "drive": "rig drive --emulate epos4 status   (then enable, jog 10 --for 1, disable, ...)",
    "emulate": "rig emulate --preset dc-servo   (then, in another terminal, rig scan --interface "
    "socketcand --channel can0)",
    "faults": "rig faults --scenario tpdo-stall --scenario host-sigkill",
    "sweep": "rig sweep examples/sweeps/servo_b_m.toml --workers 2 --plot sweep-plots",
    "bench": "rig bench loop --json",
    "doctor": "rig doctor --period 0.0004",
    "export": "rig export runs/dc-servo-position-DATE-TIME --format mf4",
}


def _verbose_everywhere(parser: argparse.ArgumentParser) -> None:
    """``-v`` after any subcommand too (``rig run -v ...`` as ``rig -v run ...``)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                child.add_argument(
                    "-v",
                    "--verbose",
                    action="store_true",
                    default=argparse.SUPPRESS,
                    help="log debug messages to stderr, with tracebacks",
                )
                child.set_defaults(prog=child.prog)  # the deepest parsed wins: it names the command
                _verbose_everywhere(child)


def _said(exc: Exception) -> str:
    """A toolkit error's line: ``rig: `` before it, unless it names its subcommand already."""
    text = str(exc)
    return text if text.startswith("rig ") else f"rig: {text}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``rig`` command line; returns the process exit code."""
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:  # named by the subcommand that was given them, not by the top parser
            raise UsageError(f"{getattr(args, 'prog', 'rig')}: unrecognized arguments: {' '.join(extra)}")
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter((logging.Formatter if args.verbose else BriefFormatter)(FORMAT))
        logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING, handlers=[handler])
        if not args.verbose:  # the drivers say what failed in their own words (unit, register; node, object)
            logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
            logging.getLogger("canopen.sdo.client").setLevel(logging.CRITICAL)
        return int(args.handler(args))
    except UsageError as exc:
        print(str(exc), file=sys.stderr)
        return EXIT_USAGE
    except ConfigError as exc:
        print(_said(exc), file=sys.stderr)
        return EXIT_USAGE
    except RigError as exc:
        print(_said(exc), file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("rig: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # ``rig ... | head``: the reader left; no traceback at exit either
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + 13  # as a process SIGPIPE ended
