"""What every subcommand of ``rig`` shares: the usage error, number options, --json, --param, bus options.

Conventions: ``--help`` on every level; ``--json`` prints one JSON document on
stdout and nothing else there; a bad argument gives one line on stderr naming
it and exit code 2; the exit codes are ``EXIT_CODES``, the same for every command.

The parts live in modules named for what they hold, and are exported here as well:
``rig.cli.exits`` (the exit codes), ``rig.cli.usage`` (the usage error, the parser),
``rig.cli.option_types`` (argparse types), ``rig.cli.plot_option`` (``--plot``) and
``rig.cli.bus_options`` (the CAN bus options).
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from typing import Any

from drivers.errors import ConfigError
from rig.cli.bus_options import add_bus_arguments, open_network
from rig.cli.exits import (
    EXIT_CODES,
    EXIT_NOT_WRITTEN,
    EXIT_STOPPED,
    EXIT_UNCONFIRMED,
    EXIT_UNTRUSTED,
    EXIT_USAGE,
    exit_code,
    not_written,
)
from rig.cli.option_types import finite, out_file, tcp_port, tcp_port_or_any
from rig.cli.plot_option import add_plot, plot_folder
from rig.cli.usage import Lazy, Parser, UsageError
from rig.config.params import parse_items, typed_values

__all__ = [
    "EXIT_CODES",
    "EXIT_NOT_WRITTEN",
    "EXIT_STOPPED",
    "EXIT_UNCONFIRMED",
    "EXIT_UNTRUSTED",
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
