"""One table of a TOML file read key by key, for a checked loader (``plant_emulator.device_profile``):
each key's type is checked as it is read, and the keys nobody read are refused by name."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError

__all__ = ["Table"]


class Table:
    """One TOML table of file ``path`` (``section``: its dotted name), for messages; every key read
    is ticked off, and ``done`` names the keys nobody read.

    Parameters
    ----------
    data : Mapping[str, Any]
        The table.
    path : Path
        Its file.
    section : str, optional
        Its dotted name ("": the top).
    """

    def __init__(self, data: Mapping[str, Any], path: Path, section: str = "") -> None:
        self.data, self.path, self.section = data, path, section
        self.read: set[str] = set()
        self.where = f"{path} [{section}]" if section else f"{path}:"

    def get(self, key: str, kind: type | tuple[type, ...], default: Any = None) -> Any:
        """The value of ``key``, ticked off as read; ``default`` where it is absent.

        Parameters
        ----------
        key : str
            The key.
        kind : type | tuple[type, ...]
            The type(s) it must have (an int is taken as a float).
        default : Any, optional
            Where it is absent.

        Returns
        -------
        Any
            The value.

        Raises
        ------
        ConfigError
            If it is of another type (file, table and key named).
        """
        self.read.add(key)
        if key not in self.data:
            return default
        value = self.data[key]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            name = kind.__name__ if isinstance(kind, type) else " or ".join(k.__name__ for k in kind)
            raise ConfigError(f"{self.where} {key} = {value!r}: must be {name}")
        return value

    def sub(self, key: str) -> Table:
        """The sub-table ``key`` (empty where absent).

        Parameters
        ----------
        key : str
            The key.

        Returns
        -------
        Table
            The sub-table.
        """
        return Table(self.get(key, dict, {}), self.path, f"{self.section}.{key}" if self.section else key)

    def done(self) -> None:
        """Every key was read.

        Raises
        ------
        ConfigError
            If some were not (they named).
        """
        unknown = sorted(set(self.data) - self.read)
        if unknown:
            raise ConfigError(f"{self.where}: unknown key(s) {', '.join(unknown)}")
