"""Loading an object dictionary (EDS or DCF, CiA 306) with errors that name the file."""

from __future__ import annotations

import configparser
import warnings
from pathlib import Path
from typing import Any

import canopen

from drivers.errors import ConfigError

__all__ = ["load_od"]


def load_od(path: str | Path, node_id: int) -> Any:
    """The object dictionary in ``path`` for ``node_id``; ConfigError naming the file on any defect."""
    p = Path(path)
    if p.suffix.lower() not in (".eds", ".dcf"):
        raise ConfigError(f"{p}: an object dictionary must be an .eds or .dcf file")
    try:
        with warnings.catch_warnings():  # canopen's EDS parser calls the deprecated logger.warn
            warnings.simplefilter("ignore", DeprecationWarning)
            od = canopen.import_od(str(p), node_id)
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such EDS/DCF file") from None
    except (
        configparser.Error,
        ValueError,
        KeyError,
        TypeError,
        AttributeError,
        IndexError,
        OSError,
        UnicodeDecodeError,
        canopen.ObjectDictionaryError,
    ) as exc:
        raise ConfigError(f"{p}: not a valid EDS/DCF: {type(exc).__name__}: {exc}") from exc
    for index in (0x1000, 0x1018):
        if index not in od:
            raise ConfigError(f"{p}: lacks the mandatory object 0x{index:04X}")
    return od
