"""The ``rig`` command line: ``main(argv=None) -> int`` (``entry``: the process's); one module per
subcommand.

Each subcommand module has ``add_parser(sub)``, which adds its parser and sets
its handler with ``set_defaults(handler=...)``. Only this module configures
logging, and only ``main`` answers the stop signals for the whole command (``rig.host.signals``:
SIGINT and SIGTERM whatever the parent set, SIGHUP unless ignored): a command a signal stopped
prints no result, one line on stderr, and exits 128 + the signal's number, or 4 where its
drives' stop was not confirmed. The exit codes, the same for every command, are
``rig.cli.common.EXIT_CODES`` (``rig --help``, docs/cli.md). ``-v`` goes before or after the
subcommand, and a command's options before or after its action (``rig.cli.language``: one
spelling per concept, the old ones kept a release as deprecated aliases).
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
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
    lss,
    reproduce,
    run,
    scan,
    sweep,
    tune,
    view,
)
from rig.cli.common import EXIT_CODES, EXIT_UNCONFIRMED, EXIT_USAGE, Parser, UsageError
from rig.cli.language import inherit_options
from rig.host.signals import SIGNALS, StopRequested, StopRequests, forget

__all__ = ["entry", "main"]

SUBCOMMANDS = (
    demo,
    design,
    tune,
    reproduce,
    run,
    identify,
    scan,
    drive,
    lss,
    emulate,
    faults,
    sweep,
    bench,
    doctor,
    export,
    view,
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
    parser = Parser(
        prog="rig",
        description="drive-rig: electrical-drive lab rig toolkit.",
        epilog="Exit codes, the same for every command: "
        + "; ".join(f"{code} {words}" for code, words in EXIT_CODES.items())
        + ". SIGINT and SIGTERM stop every command, whatever the parent set; rig emulate serves "
        "until one comes and then exits 0. Docs: docs/cli.md (one command language: the same option "
        "for the same thing in every command), docs/commands.md (every command).",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages to stderr")
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for module in SUBCOMMANDS:
        module.add_parser(sub)
    _verbose_everywhere(parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                child.epilog = f"Example: {EXAMPLES[name]}. Docs: docs/{DOCS[name]}, docs/commands.md"
                inherit_options(child, frozenset({"-h", "-v"}))  # before or after its action
    return parser


#: the example each subcommand's --help ends with (commands the docs pages run too)
EXAMPLES = {
    "demo": "rig demo",
    "design": "rig design dtsm --a-m 16 --b-m 680 --period 0.4e-3 --lam -15 --error-space --json",
    "reproduce": "rig reproduce dismc --json",
    "run": "rig run --config examples/dc_servo_position.toml --emulate",
    "identify": "rig identify --emulate dc-servo --param plant.a_m=23.5 --param plant.b_m=412",
    "tune": "rig tune pi-speed --from-identify runs/identify-voltage-DATE-TIME --bandwidth 20 --json",
    "scan": "rig scan --emulate dc-servo   (a real bus: rig scan --interface socketcan --channel can0)",
    "drive": "rig drive --emulate epos4 status   (then enable, jog 10 --for 1, disable, ...)",
    "lss": "rig lss --emulate epos4 scan   (a real bus: rig lss --interface socketcan --channel can0 scan)",
    "emulate": "rig emulate --preset dc-servo   (then, in another terminal, rig scan --interface "
    "socketcand --channel can0)",
    "faults": "rig faults --scenario tpdo-stall --scenario host-sigkill",
    "sweep": "rig sweep examples/sweeps/servo_b_m.toml --workers 2 --plot sweep-plots",
    "bench": "rig bench loop --json",
    "doctor": "rig doctor --period 0.0004",
    "export": "rig export runs/dc-servo-position-DATE-TIME --format mf4",
    "view": "rig view runs   (then open http://127.0.0.1:8050/ in a browser)",
}


#: the docs page each subcommand's --help points at (beside docs/commands.md), under docs/
DOCS = {
    "demo": "getting-started.md",
    "design": "tutorial-servo.md",
    "reproduce": "reproductions.md",
    "run": "running-a-rig.md",
    "identify": "identification.md",
    "tune": "tutorial-identify.md",
    "scan": "real-drives.md",
    "drive": "tutorial-commissioning.md",
    "lss": "real-drives.md",
    "emulate": "emulator.md",
    "faults": "faults.md",
    "sweep": "sweeps.md",
    "bench": "benchmarks.md",
    "doctor": "time.md",
    "export": "files.md",
    "view": "view.md",
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


#: the exit codes of a command a stop signal ended (``stopped``)
_SIGNALLED = frozenset({128 + int(s) for s in SIGNALS} | {EXIT_UNCONFIRMED})


def entry() -> NoReturn:
    """The console script ``rig`` and ``python -m rig.cli``: ``main``, then the process's end. A
    command a stop signal ended is gone at once: its exit handlers run (``atexit``: logging's
    flush, temporary folders) and its output is flushed, and the interpreter's teardown, which
    frees every module and object one by one (1.2-2.5 s at a load of 23 after a run), is skipped:
    the command ends within 2 s of the signal (docs/cli.md).

    Raises
    ------
    SystemExit
        With the exit code, where no stop signal ended the command.
    """
    code = main()
    if code in _SIGNALLED:
        atexit._run_exitfuncs()
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):  # a closed or broken stream: nothing to say
                stream.flush()
        os._exit(code)
    sys.exit(code)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``rig`` command line; returns the process exit code (``entry`` ends the process).

    Parameters
    ----------
    argv : Sequence[str] | None, optional
        The arguments (None: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code.
    """
    restore = _answer_signals()
    try:
        return _main(argv)
    finally:
        restore()


def _answer_signals() -> Callable[[], None]:
    """SIGINT and SIGTERM stop the command whatever the parent set: a background job of a
    script starts with SIGINT ignored, and a blocked signal stays blocked across exec; both are
    undone here (SIGHUP left ignored where it is: ``nohup``). Each stop signal then raises
    ``StopRequested`` once (``rig.host.signals``); returns what puts everything back."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    forget()
    mask = signal.pthread_sigmask(signal.SIG_UNBLOCK, set(SIGNALS))
    ignored = [s for s in (signal.SIGINT, signal.SIGTERM) if signal.getsignal(s) is signal.SIG_IGN]
    for sig in ignored:
        signal.signal(sig, signal.SIG_DFL)
    requests = StopRequests(doing=None)
    requests.install()

    def restore() -> None:
        requests.restore()
        for sig in ignored:
            signal.signal(sig, signal.SIG_IGN)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        forget()

    return restore


def stopped(exc: KeyboardInterrupt, who: str) -> int:
    """One line on stderr for a command a stop signal cut short, and its exit code: 128 + the
    signal's number, or 4 where its drives' stop was not confirmed."""
    if isinstance(exc, StopRequested) and exc.signum is not None:
        request = exc
    else:  # a KeyboardInterrupt not raised by our handlers: Ctrl-C
        request = StopRequested(SIGNALS[signal.SIGINT], signal.SIGINT)
    line = f"{who}: stopped by {request.reason}"
    if request.confirmed is False:
        line += "; the drives' stop was NOT confirmed: they may still be moving (the log names them)"
    elif request.confirmed:
        line += "; every drive stopped, at rest and disabled"
    if request.kept and os.path.exists(request.kept):  # not a study's temporary run, removed
        line += f"; what was done is in {request.kept}"
    print(line, file=sys.stderr)
    assert request.signum is not None
    return EXIT_UNCONFIRMED if request.confirmed is False else 128 + request.signum


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    who = "rig"
    try:
        args, extra = parser.parse_known_args(argv)
        who = getattr(args, "prog", who)
        if extra:  # named by the subcommand that was given them, not by the top parser
            raise UsageError(f"{who}: unrecognized arguments: {' '.join(extra)}")
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
    except KeyboardInterrupt as exc:  # a stop signal (rig.host.signals), after the drives' stop
        return stopped(exc, who)
    except BrokenPipeError:  # ``rig ... | head``: the reader left; no traceback at exit either
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + 13  # as a process SIGPIPE ended
