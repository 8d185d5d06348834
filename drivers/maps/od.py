"""Loading an object dictionary (EDS or DCF, CiA 306) with errors that name the file.

Every numeric DefaultValue and ParameterValue is read again (``drivers.maps.eds_values``):
one canopen left unread is refused naming the object, key and value; so is an object CiA 301/402
make an integer that the file declares another type.

CiA 306 files are meant to be ASCII; real ones carry a degree or micro sign in
a parameter name, in UTF-8 or, more often, in Windows-1252. The text is read as
UTF-8 and, where that fails, as cp1252 (which decodes any byte but five), so
both load, and canopen parses the text rather than opening the file with the
locale's encoding.
"""

from __future__ import annotations

import configparser
import io
import pickle
import warnings
from pathlib import Path
from typing import Any

import canopen

from drivers.errors import ConfigError
from drivers.files import EDS_LIMIT, read_text
from drivers.maps.eds_values import check_types, check_values

__all__ = ["eds_text", "load_od"]


def eds_text(path: str | Path) -> str:
    """The text of an EDS/DCF (a regular file of at most ``EDS_LIMIT``, ``drivers.files``):
    UTF-8, else Windows-1252 (see the module docstring).

    Parameters
    ----------
    path : str | Path
        The EDS/DCF.

    Returns
    -------
    str
        Its text.
    """
    return read_text(path, limit=EDS_LIMIT, what="EDS/DCF file", fallback="cp1252")


def load_od(path: str | Path, node_id: int) -> Any:
    """The object dictionary in ``path`` for ``node_id``; ConfigError naming the file on any defect.

    Parsed once per file (its path, size and modification time) and node id in a process: each
    caller gets its own unpickled copy (docs/real-drives.md).

    Parameters
    ----------
    path : str | Path
        The EDS/DCF.
    node_id : int
        The node it describes.

    Returns
    -------
    Any
        canopen's ``ObjectDictionary``, a copy of its own.

    Raises
    ------
    ConfigError
        If it is no .eds/.dcf, cannot be read or parsed, or a value or type is wrong.
    """
    p = Path(path)
    if p.suffix.lower() not in (".eds", ".dcf"):
        raise ConfigError(f"{p}: an object dictionary must be an .eds or .dcf file")
    try:
        stat = p.stat()
        key = (str(p.resolve()), stat.st_size, stat.st_mtime_ns, node_id)
    except OSError:
        key = None  # read_text names what is wrong with it
    blob = _PARSED.get(key) if key else None
    if blob is None:
        blob = pickle.dumps(_parse(p, node_id))
        if key is not None:
            if len(_PARSED) >= 64:
                _PARSED.pop(next(iter(_PARSED)))
            _PARSED[key] = blob
    return pickle.loads(blob)


#: parsed object dictionaries, pickled, by (path, size, mtime, node id) (``load_od``)
_PARSED: dict[tuple[str, int, int, int], bytes] = {}


def _parse(p: Path, node_id: int) -> Any:
    try:
        text = eds_text(p)
        source = io.StringIO(text)
        source.name = str(p)  # canopen picks the parser by the name's suffix
        with warnings.catch_warnings():  # canopen's EDS parser calls the deprecated logger.warn
            warnings.simplefilter("ignore", DeprecationWarning)
            od = canopen.import_od(source, node_id)
    except ConfigError:
        raise
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
        detail = " ".join(str(exc).split())[:300]  # configparser's messages span lines
        raise ConfigError(f"{p}: not a valid EDS/DCF: {type(exc).__name__}: {detail}") from exc
    for index in (0x1000, 0x1018):
        if index not in od:
            raise ConfigError(f"{p}: lacks the mandatory object 0x{index:04X}")
    check_types(od, str(p))  # an integer of CiA 301/402 declared a string, a REAL ...: refused
    check_values(od, str(p), node_id)  # a value canopen could not read: refused, naming it
    return od
