"""Reading an input file: only a regular file, only up to a size limit, errors in one line.

Every file the toolkit reads from a user goes through here: the rig configuration and
device profiles (TOML), EDS/DCF files, JSON documents (``rig identify`` results, a run's
``config.json``) and a run's ``samples.csv`` read back. It lives in ``drivers``, the lowest
layer that reads files, so that ``plant_emulator`` and ``rig`` use it too.

- A path that is not a regular file (a FIFO, a device such as ``/dev/zero``, a directory,
  a socket) is refused before it is opened for reading, so nothing blocks or runs forever;
  it is opened non-blocking all the same, and checked again once open.
- A file larger than its kind's limit (``CONFIG_LIMIT``, ``EDS_LIMIT``, ``SAMPLES_LIMIT``)
  is refused; at most ``limit + 1`` bytes are read whatever the file says its size is.
- Text must be UTF-8 (a UTF-8 byte-order mark is dropped); UTF-16 text, NUL bytes or a byte
  that is not UTF-8 are refused naming the line.
- TOML and JSON documents may nest arrays and tables ``MAX_DEPTH`` deep: deeper is refused
  naming the line (before parsing, which would recurse) or the key (after).

Every refusal is a ``ConfigError`` whose message starts with the path.
"""

from __future__ import annotations

import codecs
import json
import os
import re
import stat
import sys
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "CONFIG_LIMIT",
    "EDS_LIMIT",
    "MAX_DEPTH",
    "SAMPLES_LIMIT",
    "check_depth",
    "read_bytes",
    "read_json",
    "read_text",
    "read_toml",
]

MiB = 1 << 20
CONFIG_LIMIT = 1 * MiB  #: a rig configuration, a device profile, a JSON document
EDS_LIMIT = 8 * MiB  #: an EDS/DCF file (a vendor's lists thousands of objects)
SAMPLES_LIMIT = 256 * MiB  #: a run's samples.csv read back (hours of a fast loop)
MAX_DEPTH = 32  #: arrays and tables in arrays and tables: a configuration needs 4

_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _not_regular(path: Path, mode: int, what: str) -> ConfigError:
    kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
    return ConfigError(f"{path}: {kind}, not a regular file ({what})")


def _too_large(path: Path, size: int, limit: int, what: str) -> ConfigError:
    return ConfigError(f"{path}: {size / MiB:.1f} MiB: too large ({what}: at most {limit / MiB:g} MiB)")


def _read(p: Path, limit: int, what: str) -> bytes:
    mode = os.stat(p).st_mode  # no open yet: opening a device or a FIFO may block or act
    if not stat.S_ISREG(mode):
        raise _not_regular(p, mode, what)
    fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(f.fileno())
        if not stat.S_ISREG(st.st_mode):  # replaced between the two looks
            raise _not_regular(p, st.st_mode, what)
        if st.st_size > limit:
            raise _too_large(p, st.st_size, limit, what)
        data = f.read(limit + 1)
    if len(data) > limit:  # grew while being read, or says it has no size (as /proc does)
        raise ConfigError(f"{p}: too large ({what}: at most {limit / MiB:g} MiB)")
    return data


def read_bytes(path: str | Path, *, limit: int, what: str = "file") -> bytes:
    """The bytes of the regular file ``path``, at most ``limit``; ConfigError naming it otherwise.

    Parameters
    ----------
    path : str | Path
        The file.
    limit : int
        [bytes] the most read.
    what : str, optional
        What the file is, named in errors.

    Returns
    -------
    bytes
        Its content.

    Raises
    ------
    ConfigError
        If it is missing, not a regular file, unreadable or larger than ``limit``.
    """
    p = Path(path)
    try:
        return _read(p, limit, what)
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such {what}") from None
    except ConfigError:
        raise
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ConfigError(f"{p}: cannot read the {what}: {reason}") from None


def read_text(path: str | Path, *, limit: int, what: str = "file", fallback: str = "") -> str:
    """The UTF-8 text of ``path`` (``read_bytes``), else (``fallback``) in that 8-bit encoding;
    ConfigError naming the line of a bad byte.

    Parameters
    ----------
    path : str | Path
        The file.
    limit : int
        [bytes] the most read.
    what : str, optional
        What the file is, named in errors.
    fallback : str, optional
        An 8-bit encoding tried where the text is not UTF-8 ("": none).

    Returns
    -------
    str
        Its text.

    Raises
    ------
    ConfigError
        As ``read_bytes``, or for UTF-16/32 text, a NUL byte or a byte neither encoding takes (its line
        named).
    """
    p = Path(path)
    data = read_bytes(p, limit=limit, what=what)
    if data.startswith((codecs.BOM_UTF32_LE, codecs.BOM_UTF32_BE)):
        raise ConfigError(f"{p}: UTF-32 text: save the {what} as UTF-8")
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        raise ConfigError(f"{p}: UTF-16 text: save the {what} as UTF-8")
    nul = data.find(b"\0")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        raise ConfigError(f"{p}: line {line}: a NUL byte: the {what} is not text (or is UTF-16, not UTF-8)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        if not fallback:
            raise _bad_byte(p, data, exc, what, "is not UTF-8 text") from None
    try:
        return data.decode(fallback)
    except UnicodeDecodeError as exc:
        raise _bad_byte(p, data, exc, what, f"is neither UTF-8 nor {fallback}") from None


def _bad_byte(p: Path, data: bytes, exc: UnicodeDecodeError, what: str, rule: str) -> ConfigError:
    line = data.count(b"\n", 0, exc.start) + 1
    return ConfigError(f"{p}: not a valid {what}: line {line}: byte 0x{data[exc.start]:02X} {rule}")


#: what can nest in TOML or JSON text: strings (whose brackets do not count), comments, brackets
_TOKENS = re.compile(
    r'"""(?:\\.|[^\\])*?"""|\'\'\'.*?\'\'\'|"(?:\\.|[^"\\\n])*"|\'[^\'\n]*\'|#[^\n]*|[\[\]{}]',
    re.DOTALL,
)


def _check_text_depth(text: str, source: str, limit: int) -> None:
    """Refuse brackets nested deeper than ``limit`` outside strings and comments, naming the line."""
    depth = 0
    for token in _TOKENS.finditer(text):
        t = token.group()
        if t in ("[", "{"):
            depth += 1
            if depth > limit:
                start = text.rfind("\n", 0, token.start()) + 1
                line = text.count("\n", 0, start) + 1
                snippet = text[start : start + 40].split("\n", maxsplit=1)[0]
                raise ConfigError(f"{source}: line {line}: {snippet}...: nested deeper than {limit} levels")
        elif t in ("]", "}"):
            depth = max(0, depth - 1)


def check_depth(doc: Any, source: str, limit: int = MAX_DEPTH) -> None:
    """Refuse a parsed document with tables or arrays nested deeper than ``limit``, naming the key.

    Parameters
    ----------
    doc : Any
        A parsed TOML or JSON document.
    source : str
        The file it came from, named in the error.
    limit : int, optional
        The deepest nesting allowed.

    Raises
    ------
    ConfigError
        If tables or arrays nest deeper than ``limit`` (the key named).
    """
    stack: list[tuple[Any, str, int]] = [(doc, "", 0)]
    while stack:
        value, key, depth = stack.pop()
        if depth > limit:
            raise ConfigError(f"{source}: {key[:80]}: nested deeper than {limit} levels")
        if isinstance(value, dict):
            stack.extend((v, f"{key}.{k}" if key else str(k), depth + 1) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, f"{key}[{i}]", depth + 1) for i, v in enumerate(value))


def read_toml(path: str | Path, *, limit: int = CONFIG_LIMIT, what: str = "TOML file") -> dict[str, Any]:
    """The TOML document in ``path`` (``read_text``, depth checked); ConfigError naming the file.

    Parameters
    ----------
    path : str | Path
        The file.
    limit : int, optional
        [bytes] the most read.
    what : str, optional
        What the file is, named in errors.

    Returns
    -------
    dict[str, Any]
        The document.

    Raises
    ------
    ConfigError
        If it cannot be read (``read_text``), is not valid TOML or nests too deep.
    """
    text = read_text(path, limit=limit, what=what)
    _check_text_depth(text, str(path), MAX_DEPTH)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:  # pragma: no cover - the depth check comes first
        raise ConfigError(f"{path}: nested too deep") from None
    check_depth(doc, str(path))
    return doc


def read_json(path: str | Path, *, limit: int = CONFIG_LIMIT, what: str = "JSON file") -> Any:
    """The JSON document in ``path`` (``read_text``, depth checked); ConfigError naming the file.

    Parameters
    ----------
    path : str | Path
        The file.
    limit : int, optional
        [bytes] the most read.
    what : str, optional
        What the file is, named in errors.

    Returns
    -------
    Any
        The document.

    Raises
    ------
    ConfigError
        If it cannot be read (``read_text``), is not valid JSON or nests too deep.
    """
    text = read_text(path, limit=limit, what=what)
    _check_text_depth(text, str(path), MAX_DEPTH)
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise ConfigError(f"{path}: not valid JSON: {exc}") from None
    except RecursionError:  # pragma: no cover - the depth check comes first
        raise ConfigError(f"{path}: nested too deep") from None
    check_depth(doc, str(path))
    return doc
