"""What every subcommand of ``rig`` shares: the usage error, number options, --json, --param, bus options.

Conventions: ``--help`` on every level; ``--json`` prints one JSON document on
stdout and nothing else there; a bad argument gives one line on stderr naming
it and exit code 2; the exit codes are ``EXIT_CODES``, the same for every command.
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

from drivers.errors import ConfigError
from rig.config.params import parse_items, typed_values

__all__ = [
    "EXIT_CODES",
    "EXIT_NOT_WRITTEN",
    "EXIT_STOPPED",
    "EXIT_UNCONFIRMED",
    "EXIT_USAGE",
    "Lazy",
    "Parser",
    "UsageError",
    "add_bus_arguments",
    "add_json",
    "add_params",
    "add_plot",
    "emulated",
    "exit_code",
    "finite",
    "json_clean",
    "not_written",
    "open_network",
    "out_file",
    "params_of",
    "plot_folder",
    "print_json",
    "tcp_port",
    "tcp_port_or_any",
]

EXIT_USAGE = 2
EXIT_STOPPED = 3
EXIT_UNCONFIRMED = 4  #: the drives' stop could not be confirmed: they may still be moving
EXIT_UNTRUSTED = 5  #: rig identify --strict: closed-loop data or a poor held-out fit
EXIT_NOT_WRITTEN = 6  #: a file of the run is missing or cut short (``files_not_written``)

#: every exit code of ``rig`` and what it says, the same for every command (``rig --help`` and
#: docs/cli.md show them; ``rig.cli.stopped`` makes the stop signals')
EXIT_CODES = {
    "0": "done",
    "1": "a failure (of the rig: communication, a device; or of the command)",
    "2": "a bad argument or configuration (one line on stderr naming it)",
    "3": "a safety stop (a limit, the watchdog, a device fault, ...), every drive confirmed at rest "
    "and disabled",
    "4": "a stop not confirmed, whatever began it (a safety stop or a signal): a drive may still be moving",
    "5": "--strict (rig identify, rig tune) and a warning",
    "6": "a file of the run not written whole (named on stderr)",
    "128+N": "stopped by signal N (130 Ctrl-C/SIGINT, 143 SIGTERM, 129 SIGHUP), every drive the command "
    "moved confirmed at rest; no result printed, one line on stderr saying what was kept",
    "141": "the reader of stdout left (rig ... | head)",
}


def exit_code(summary: dict[str, Any]) -> int:
    """A run's exit code: 0 done, 3 a safe stop, 6 a file of the run not written whole, 4 a stop
    not confirmed (before all: never like a clean one).

    Parameters
    ----------
    summary : dict[str, Any]
        The run's summary.

    Returns
    -------
    int
        0, 3, 4 or 6.
    """
    if summary.get("stop_confirmed") is False:
        return EXIT_UNCONFIRMED
    if summary.get("files_not_written"):
        return EXIT_NOT_WRITTEN
    return 0 if summary.get("safe_stop_reason") is None else EXIT_STOPPED


def not_written(summary: dict[str, Any], who: str) -> str | None:
    """One line naming the run's files not written whole and the samples not on disk (None: all
    written); where summary.json is among them, the summary printed is its only copy.

    Parameters
    ----------
    summary : dict[str, Any]
        The run's summary.
    who : str
        The command, named in the line.

    Returns
    -------
    str | None
        The line, or None.
    """
    files = summary.get("files_not_written") or []
    if not files:
        return None
    line = f"{who}: not written whole in {summary.get('run_dir')}: {', '.join(files)}"
    lost = summary.get("samples_not_written") or 0
    if lost:
        line += f"; {lost} samples not in samples.csv"
    if "summary.json" in files:
        line += "; the summary printed here is its only copy"
    return line + " (reasons: the summary's warnings)"


class UsageError(Exception):
    """A command-line argument is wrong; the message names it."""


class Lazy:
    """A help text made when it is first read (``Parser.description``): a text that needs a heavy
    module (numpy, a paper's study) costs nothing to a command that does not show it.

    Parameters
    ----------
    make : Callable[[], str]
        Makes the text.
    """

    def __init__(self, make: Callable[[], str]) -> None:
        self.make = make


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line, raised instead of exiting; its description may be
    ``Lazy``, made when read; a repeatable option given before and after an action keeps both
    (``rig.cli.language.MergingSubParsers``).

    Parameters
    ----------
    *args : Any
        ``argparse.ArgumentParser``'s.
    **kw : Any
        ``argparse.ArgumentParser``'s.
    """

    _text: str | Lazy | None = None  #: the description as given: made on first read if Lazy

    def __init__(self, *args: Any, **kw: Any) -> None:
        from rig.cli.language import MergingSubParsers

        super().__init__(*args, **kw)
        self.register("action", "parsers", MergingSubParsers)

    @property
    def description(self) -> str | None:
        if isinstance(self._text, Lazy):
            self._text = self._text.make()
        return self._text

    @description.setter
    def description(self, text: str | Lazy | None) -> None:
        self._text = text

    def error(self, message: str) -> NoReturn:
        """Raise the usage error as one line (argparse would exit).

        Parameters
        ----------
        message : str
            argparse's words.

        Raises
        ------
        UsageError
            Always.
        """
        raise UsageError(f"{self.prog}: {message}")


def finite(text: str) -> float:
    """An argparse type: a finite number.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    float
        The number.

    Raises
    ------
    ArgumentTypeError
        If it is not a finite number.
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def tcp_port(text: str) -> int:
    """An argparse type: a TCP port 1..65535.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    int
        The port.
    """
    return _port(text, 1)


def tcp_port_or_any(text: str) -> int:
    """An argparse type: a TCP port to listen on, 0..65535 (0: any free port).

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    int
        The port.
    """
    return _port(text, 0)


def _port(text: str, low: int) -> int:
    try:
        port = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a port number: {text!r}") from None
    if not low <= port <= 65535:
        raise argparse.ArgumentTypeError(f"must be {low}..65535, got {port}")
    return port


def out_file(text: str) -> str:
    """An argparse type: a file to write (a plot): not a directory, in a folder that is there.

    Parameters
    ----------
    text : str
        The option's value.

    Returns
    -------
    str
        ``text``.

    Raises
    ------
    ArgumentTypeError
        If it is a directory, or its folder is missing.
    """
    path = pathlib.Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: a directory, not a file")
    if not path.resolve().parent.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: no folder {path.parent} to write it in")
    return text


#: a name with one of these is a figure's file, not a folder (``--plot``)
IMAGE_SUFFIXES = frozenset({".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp"})


def add_plot(parser: argparse.ArgumentParser, what: str) -> None:
    """``--plot DIR``: ``what`` written into the folder DIR (``plot_folder``).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    what : str
        The figures, named in the help.
    """
    parser.add_argument(
        "--plot",
        metavar="DIR",
        help=f"write {what} into the folder DIR (made if missing, before anything runs; needs matplotlib)",
    )


def plot_folder(args: argparse.Namespace, who: str, *, old_file: bool = False) -> pathlib.Path | None:
    """The folder of ``--plot``, made now and matplotlib checked: said before anything runs.

    A name with an image suffix is refused, or, where ``old_file`` (the command wrote one file
    before), taken as the old form for this release: a warning on stderr, and ``args.plot_file``
    is that file (None otherwise).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options (``args.plot``); ``args.plot_file`` is set.
    who : str
        The command, named in errors.
    old_file : bool, optional
        Take a file name as the deprecated form (the command wrote one file before).

    Returns
    -------
    pathlib.Path | None
        The folder, made; None without ``--plot``.

    Raises
    ------
    UsageError
        If it names a file where a folder is asked for, matplotlib is missing, or the folder
        cannot be made.
    """
    args.plot_file = None
    if args.plot is None:
        return None
    path = pathlib.Path(args.plot)
    folder = path
    if path.suffix.lower() in IMAGE_SUFFIXES and not path.is_dir():
        if not old_file:
            raise UsageError(
                f"{who}: --plot {args.plot}: give a folder (its figures go in it, each named for what it "
                "shows), not a file name"
            )
        folder, args.plot_file = path.parent, str(path)
        print(
            f"{who}: --plot {args.plot}: a file is deprecated (kept for this release): give a folder, "
            f"--plot {folder}",
            file=sys.stderr,
        )
    from rig.report.plots import require_pyplot

    try:
        require_pyplot()
        folder.mkdir(parents=True, exist_ok=True)
    except ConfigError as exc:
        raise UsageError(f"{who}: {exc}") from None
    except OSError as exc:
        raise UsageError(
            f"{who}: --plot {args.plot}: cannot make the folder {folder}: {exc.strerror}"
        ) from None
    return folder


def emulated(name: str, who: str) -> tuple[str, Any]:
    """What ``--emulate NAME`` names: a preset, a zoo twin or a profile file (.toml).

    Parameters
    ----------
    name : str
        The option's value.
    who : str
        The command, named in errors.

    Returns
    -------
    tuple[str, Any]
        ("preset", ``name``), or ("device", the twin's ``DeviceProfile``).

    Raises
    ------
    UsageError
        If it is neither, naming what there is.
    """
    from plant_emulator.device_profile import device_profile, zoo
    from plant_emulator.presets import PRESETS

    if name in PRESETS:
        return "preset", name
    if name in zoo() or name.endswith(".toml"):
        return "device", device_profile(name)
    raise UsageError(
        f"{who}: --emulate {name}: neither a preset ({', '.join(PRESETS)}) nor a zoo twin "
        f"({', '.join(zoo())}) nor a profile file (.toml)"
    )


def add_json(parser: argparse.ArgumentParser, what: str = "print one JSON document") -> None:
    """A ``--json`` flag.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    what : str, optional
        Its help.
    """
    parser.add_argument("--json", action="store_true", help=what)


def add_params(parser: argparse.ArgumentParser, help: str, *, flag: str = "--param") -> None:
    """A repeatable ``--param NAME=VALUE`` (or ``flag``) option.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    help : str
        Its help.
    flag : str, optional
        The option's name.
    """
    parser.add_argument(flag, action="append", default=[], metavar="NAME=VALUE", help=help)


def params_of(items: Sequence[str], schema: type, source: str, **kw: Any) -> dict[str, Any]:
    """``--param`` items typed against ``schema`` (``rig.config.params.typed_values``); UsageError
    when bad.

    Parameters
    ----------
    items : Sequence[str]
        The ``NAME=VALUE`` items.
    schema : type
        A dataclass.
    source : str
        The option, named in errors.
    **kw : Any
        ``typed_values``' keywords.

    Returns
    -------
    dict[str, Any]
        Field -> typed value.

    Raises
    ------
    UsageError
        If an item is malformed, unknown or of a wrong type.
    """
    try:
        return typed_values(schema, parse_items(items, source), source, text=True, **kw)
    except ConfigError as exc:
        raise UsageError(str(exc)) from None


def add_bus_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that open a CAN bus (python-can interface and channel, socketcand address).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    group = parser.add_argument_group("CAN bus")
    group.add_argument("--interface", help="python-can interface (e.g. socketcan, socketcand, pcan)")
    group.add_argument("--channel", help="python-can channel (e.g. vcan0, can0)")
    group.add_argument(
        "--bitrate", type=int, help="bit rate [bit/s] where the interface sets it (e.g. 500000)"
    )
    group.add_argument("--host", default="127.0.0.1", help="socketcand host (default 127.0.0.1)")
    group.add_argument("--port", type=tcp_port, default=29536, help="socketcand port (default 29536)")


def open_network(args: argparse.Namespace, who: str) -> Any:
    """A connected canopen network on the bus of ``add_bus_arguments``' options.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.
    who : str
        The command, named in errors.

    Returns
    -------
    Any
        The canopen network, connected.

    Raises
    ------
    UsageError
        If the options name no bus, or a bit rate not > 0, or it cannot open.
    """
    import canopen

    from drivers.bus import check_interface, open_bus

    if not (args.interface and (args.channel or args.interface == "socketcand")):
        raise UsageError(f"{who}: give --interface and --channel, or --emulate NAME")
    try:
        check_interface(args.interface, f"{who}: argument --interface")
    except ConfigError as exc:
        raise UsageError(str(exc)) from None
    if args.bitrate is not None and args.bitrate <= 0:
        raise UsageError(f"{who}: argument --bitrate: must be > 0 bit/s, got {args.bitrate}")
    extra = {"host": args.host, "port": args.port} if args.interface == "socketcand" else {}
    network = canopen.Network(open_bus(args.interface, args.channel or "can0", bitrate=args.bitrate, **extra))
    network.NOTIFIER_CYCLE = (
        0.1  # [s] the receive thread's wait: closing takes at most that, not canopen's 1 s
    )
    network.connect()
    return network


def json_clean(value: Any) -> Any:
    """``value`` with non-finite floats as null (JSON has no inf or NaN).

    Parameters
    ----------
    value : Any
        A JSON-ready value.

    Returns
    -------
    Any
        It with NaN and inf as None.
    """
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_clean(v) for v in value]
    return value


def print_json(value: Any) -> None:
    """``value`` as one JSON document on stdout (``json_clean``).

    Parameters
    ----------
    value : Any
        A JSON-ready value.
    """
    print(json.dumps(json_clean(value)))
