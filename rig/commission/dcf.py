"""A device configuration file (DCF, CiA 306) of one drive: the EDS in use, each object's value as
the drive holds it, and where the drive sits on the bus.

``dcf_text`` edits the EDS's text rather than writing a new file, so the vendor's sections, key
order and comments stay as they were: each object the dump read gets ``ParameterValue=`` in its
own section (a VAR's ``[6081]``, a record's or array's entry's ``[1018sub1]``; one there already,
in a DCF given as the dictionary, is replaced); ``[FileInfo]`` names the file (``FileName``) and
the EDS it came from (``LastEDS``); ``[DeviceComissioning]`` (CiA 306's spelling) gives
``NodeID``, ``NodeName`` (0x1008 where the drive has it), ``Baudrate`` [kbit/s] where the bus's is
known, ``NetNumber``, ``NetworkName``, ``CANopenManager`` (0: a drive) and ``LSS_SerialNumber``
(0x1018:04). Values are written as CiA 306 reads them: an unsigned integer in hex, a signed one in
decimal, a REAL as a decimal number, a VISIBLE_STRING as its text on one line, an OCTET_STRING as
hex digits. Objects not read (refused, write-only, DOMAIN) get no ParameterValue: their
DefaultValue stands. An object of compact storage (``CompactSubObj``, no section per entry)
keeps its EDS form: its values are in the dump, not the DCF.

The toolkit's loader (``drivers.maps.od.load_od``) and canopen's ``import_od`` read the file
back, ParameterValue as each object's value.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from canopen.objectdictionary import FLOAT_TYPES, SIGNED_TYPES

from drivers.maps.eds_values import TYPE_NAMES
from rig.commission.dictionary import Entry

__all__ = ["dcf_text"]

_HEADER = re.compile(r"^\s*\[([^\]]+)\]\s*$")
_KEY = re.compile(r"^\s*([^=;#\s][^=]*?)\s*=")
_ENTRY = re.compile(r"^([0-9A-Fa-f]{4})(?:sub([0-9A-Fa-f]+))?$", re.IGNORECASE)
_SIGNED = frozenset(TYPE_NAMES[t] for t in SIGNED_TYPES if t in TYPE_NAMES)
_FLOAT = frozenset(TYPE_NAMES[t] for t in FLOAT_TYPES if t in TYPE_NAMES)


def _text(entry: Entry) -> str:
    """``entry``'s value as CiA 306 writes a ParameterValue."""
    value = entry.value
    if isinstance(value, bytes):
        return value.hex().upper()
    if isinstance(value, str):
        return " ".join(value.splitlines())
    if entry.type in _FLOAT:
        return repr(float(value))
    if entry.type in _SIGNED:
        return str(int(value))
    return f"0x{int(value):X}"


def _sections(lines: list[str]) -> list[tuple[str | None, list[str]]]:
    """The text's lines as (section name, its lines: the header first), the lines before the
    first header under None."""
    out: list[tuple[str | None, list[str]]] = [(None, [])]
    for line in lines:
        m = _HEADER.match(line)
        if m:
            out.append((m.group(1).strip(), [line]))
        else:
            out[-1][1].append(line)
    return out


def _set(body: list[str], key: str, value: str) -> list[str]:
    """``body`` (a section's lines, header first) with ``key=value`` in place of the key's line, or
    after the last line that is not blank."""
    line = f"{key}={value}"
    for i, old in enumerate(body):
        m = _KEY.match(old)
        if i and m and m.group(1).lower() == key.lower():
            return [*body[:i], line, *body[i + 1 :]]
    end = len(body)
    while end > 1 and not body[end - 1].strip():
        end -= 1
    return [*body[:end], line, *body[end:]]


def _target(name: str) -> tuple[int, int | None] | None:
    """(index, sub-index; None: the object's own section) of an object's section name."""
    m = _ENTRY.match(name)
    if m is None:
        return None
    return int(m.group(1), 16), None if m.group(2) is None else int(m.group(2), 16)


def dcf_text(
    eds: str,
    entries: Iterable[Entry],
    *,
    eds_path: str,
    dcf_path: str,
    node_id: int,
    node_name: str,
    bitrate: int | None,
    serial: int | None,
) -> str:
    """The DCF of ``eds`` (the EDS/DCF text in use, from ``eds_path``) with the values of
    ``entries``, for the node ``node_id`` on a bus of ``bitrate`` [bit/s] (None: not known).

    Parameters
    ----------
    eds : str
        The EDS/DCF text in use.
    entries : Iterable[rig.commission.dictionary.Entry]
        The values read.
    eds_path : str
        Its file.
    dcf_path : str
        The DCF's file.
    node_id : int
        The node.
    node_name : str
        Its name.
    bitrate : int | None
        [bit/s] the bus's (None: not known).
    serial : int | None
        Its serial number (None: not read).

    Returns
    -------
    str
        The DCF text.
    """
    out = _with_values(eds, _values(entries), eds_path=eds_path, dcf_path=dcf_path)
    return "\n".join(out + _commissioning(node_id, node_name, bitrate, serial)) + "\n"


def _values(entries: Iterable[Entry]) -> dict[tuple[int, int | None], str]:
    """The values read, as a DCF writes them: (index, subindex; None for a whole object) -> text."""
    values: dict[tuple[int, int | None], str] = {}
    for e in entries:
        if e.refused is None and e.value is not None:
            values[(e.index, None if e.whole else e.subindex)] = _text(e)
    return values


def _with_values(
    eds: str, values: dict[tuple[int, int | None], str], *, eds_path: str, dcf_path: str
) -> list[str]:
    """The lines of ``eds`` with each object's ParameterValue of ``values``, its FileInfo naming the
    DCF and the EDS, without its [DeviceComissioning] or trailing blank lines."""
    out: list[str] = []
    for name, body in _sections(eds.splitlines()):
        if name is None:
            out += body
            continue
        if name.lower() == "devicecomissioning":
            continue  # written anew (_commissioning)
        lines = body
        if name.lower() == "fileinfo":
            lines = _set(_set(lines, "FileName", Path(dcf_path).name), "LastEDS", Path(eds_path).name)
        target = _target(name)
        if target is not None and target in values:
            lines = _set(lines, "ParameterValue", values[target])
        out += lines
    while out and not out[-1].strip():
        out.pop()
    return out


def _commissioning(node_id: int, node_name: str, bitrate: int | None, serial: int | None) -> list[str]:
    """The [DeviceComissioning] section of the node ``node_id`` (its lines, a blank one first)."""
    return [
        "",
        "[DeviceComissioning]",
        f"NodeID={node_id}",
        f"NodeName={' '.join(node_name.split()) or f'node {node_id}'}",
        *([f"Baudrate={bitrate // 1000}"] if bitrate else []),
        "NetNumber=1",
        "NetworkName=drive-rig",
        "CANopenManager=0",
        *([f"LSS_SerialNumber={serial}"] if serial is not None else []),
    ]
