"""``rig drive dump``: every object of a drive's dictionary with the value the drive holds now, read
by SDO, as EPOS Studio's and TwinCAT's object dictionary pages show it.

``read_dictionary`` reads each variable the EDS/DCF in use names (each entry of a record or array,
sub-index 0 too) by SDO upload, in index order. Without a dictionary of the device's own (none
given: the toolkit's generic CiA 402 one), a drive that is not the toolkit's own is read only for
the standard objects (CiA 301 and CiA 402: 0x1000-0x1FFF, 0x6000-0x9FFF): what the generic
dictionary says of 0x2000-0x5FFF is the toolkit's drive's, not this one's. An object the drive
refuses (an SDO abort), a write-only object and a DOMAIN (a firmware image, a program: read it
with ``rig drive sdo read``) are listed with why they were not read; none of them is an error.
An answer whose size is not the type's is listed as refused too, with the bytes the drive sent.

Each ``Entry`` has the object's name, CiA 301 type and access as the dictionary gives them, the
value decoded by that type, the value in hex (an integer at its type's width, two's complement
for a negative one; a REAL's bit pattern) and, where the object holds a quantity
(``rig.commission.quantities``), that quantity in SI and the drive's unit in words.
``dump_lines`` lays it out for a person: one row per object, the values in SI in a column.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from canopen.objectdictionary import DOMAIN, FLOAT_TYPES, INTEGER_TYPES

from drivers.cia402 import Cia402Axis
from drivers.errors import CommunicationTimeout, DictionaryMismatch, SdoAbort
from drivers.maps.cia import MANUFACTURER_AREA
from drivers.maps.eds_values import TYPE_NAMES, variables
from drivers.maps.sdo_aborts import abort_text
from drivers.sdo_answer import sized
from drivers.sdo_errors import sdo_errors
from rig.commission.quantities import quantity

__all__ = ["Entry", "dump_lines", "read_dictionary"]

#: [objects] answered in a row with no answer at all: the node has gone (a timeout each is slow)
_SILENT = 3


@dataclass
class Entry:
    """One variable of the dictionary and what the drive answered (see the module docstring)."""

    index: int  #: the object's index
    subindex: int  #: its subindex
    name: str  #: its name in the EDS
    type: str  #: its data type, in words
    access: str  #: its access type in the EDS
    value: Any = None  #: decoded by the type (int, float, str, bytes); None where not read
    hex: str = ""  #: the bytes answered, in hex
    #: the quantity it holds (``Quantity.as_dict``: value in SI, None where no factor is known)
    quantity: dict[str, Any] | None = None
    refused: str | None = None  #: why it was not read (None: it was)
    whole: bool = True  #: a VAR (its value in the object's own section of the EDS), not an entry

    @property
    def key(self) -> str:
        return f"0x{self.index:04X}:{self.subindex:02X}"

    def as_dict(self) -> dict[str, Any]:
        """For ``--json``: the object as ``index:sub``, bytes as hex.

        Returns
        -------
        dict[str, Any]
            The entry.
        """
        out = {"object": self.key, **asdict(self)}
        for gone in ("index", "subindex", "whole"):
            out.pop(gone)
        if isinstance(out["value"], bytes):
            out["value"] = out["value"].hex()
        return out


def _hex(var: Any, value: Any, data: bytes) -> str:
    """``value`` in hex: an integer at its type's width (two's complement), a REAL's bits."""
    if var.data_type in INTEGER_TYPES or var.data_type == 0x01:
        bits = len(var)
        return f"0x{int(value) & ((1 << bits) - 1):0{bits // 4}X}"
    if var.data_type in FLOAT_TYPES:
        return "0x" + data[::-1].hex().upper()
    return ""


def _entry(var: Any, od: Any) -> Entry:
    """The entry of canopen variable ``var`` before it is read."""
    parent = od[var.index]
    whole = not hasattr(parent, "subindices")
    name = var.name if whole else f"{parent.name}: {var.name}"
    kind = TYPE_NAMES.get(var.data_type, f"0x{var.data_type:04X}")
    return Entry(var.index, var.subindex, name, kind, var.access_type, whole=whole)


def _upload(axis: Cia402Axis, var: Any) -> bytes:
    """The object's bytes as the drive answers, cut to its type (``drivers.sdo_answer``)."""
    node, number, eds = axis.node_id, axis.axis_number, axis.eds
    with (
        sdo_errors("SDO upload", var.index, var.subindex, node_id=node, axis=number, eds=eds),
        axis.node.sdo.open(var.index, var.subindex, buffering=0) as fp,
    ):
        data, indicated = fp.read(), fp.size
    return sized(var, bytes(data), indicated, node_id=axis.node_id, source=axis.eds)


def read_dictionary(axis: Cia402Axis, *, standard_only: bool) -> list[Entry]:
    """Every variable of ``axis``'s dictionary, read from the drive (see the module docstring);
    ``standard_only``: not 0x2000-0x5FFF. ``axis.units`` (``discover``) give the quantities.
    CommunicationTimeout where the drive stops answering (``_SILENT`` objects in a row).

    Parameters
    ----------
    axis : Cia402Axis
        The drive, discovered.
    standard_only : bool
        Skip 0x2000-0x5FFF.

    Returns
    -------
    list[Entry]
        One entry a variable.

    Raises
    ------
    CommunicationTimeout
        If the drive stops answering.
    """
    od = axis.node.object_dictionary
    od = getattr(od, "device", od)  # the node's whole dictionary, each object at its own index
    units = getattr(axis, "units", None)
    entries: list[Entry] = []
    silent = 0
    for var in sorted(variables(od), key=lambda v: (v.index, v.subindex)):
        if standard_only and var.index in MANUFACTURER_AREA:
            continue
        entry = _entry(var, od)
        entries.append(entry)
        if not var.readable:
            entry.refused = "write-only: not read"
            continue
        if var.data_type == DOMAIN:
            entry.refused = f"DOMAIN: not read (rig drive sdo read {entry.key} reads it)"
            continue
        try:
            data = _answer(axis, var, entry)
        except CommunicationTimeout as exc:
            silent += 1
            if silent >= _SILENT:
                raise CommunicationTimeout(
                    f"node {axis.node_id} stopped answering at {entry.key} ({silent} objects unanswered)"
                ) from exc
            entry.refused = "no SDO answer"
            continue
        silent = 0
        if data is not None:
            _fill(entry, var, data, units)
    return entries


def _answer(axis: Cia402Axis, var: Any, entry: Entry) -> bytes | None:
    """The drive's answer for ``var`` (None: refused, why in ``entry.refused``); a
    CommunicationTimeout where it gave none."""
    try:
        return _upload(axis, var)
    except SdoAbort as exc:
        entry.refused = f"SDO abort 0x{exc.code:08X}: {abort_text(exc.code)}"
    except DictionaryMismatch as exc:
        entry.refused = "the answer is not its type's size: " + str(exc).split("but the device ")[-1]
    return None


def _fill(entry: Entry, var: Any, data: bytes, units: Any) -> None:
    """``entry``'s value, its hex and (``units`` known, a number) its quantity, of the answer ``data``."""
    entry.value = var.decode_raw(data)
    entry.hex = _hex(var, entry.value, data)
    numeric = isinstance(entry.value, (int, float)) and not isinstance(entry.value, bool)
    if numeric and units is not None and (entry.whole or var.subindex):  # a record's sub 0: a count
        held = quantity(units, var.index, entry.value)
        entry.quantity = held.as_dict() if held is not None else None


def _shown(row: dict[str, Any]) -> str:
    """The value of a row of ``Entry.as_dict`` as the table shows it: hex and decimal for an
    integer, the text of a string, the bytes of an octet string in hex."""
    value = row["value"]
    if row["type"] in ("OCTET_STRING", "DOMAIN"):
        return " ".join(value[i : i + 2] for i in range(0, len(value), 2)) or "(empty)"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, float):
        return f"{value:.6g} ({row['hex']})"
    return f"{row['hex']} = {value}"


def _si(held: dict[str, Any] | None) -> str:
    """A quantity's value in SI with its unit; its unit on the drive where no factor is known."""
    if held is None:
        return ""
    if held["value"] is None:
        return str(held["drive_unit"]).split(" (")[0]
    return f"{held['value']:.6g} {held['unit']}"


def dump_lines(rows: list[dict[str, Any]], heading: str) -> list[str]:
    """The dump for a person (rows of ``Entry.as_dict``): ``heading``, then one row per object
    (object, access, type, value, the quantity in SI), the name on the row's right.

    Parameters
    ----------
    rows : list[dict[str, Any]]
        ``Entry.as_dict``'s.
    heading : str
        The first line.

    Returns
    -------
    list[str]
        The lines.
    """
    read = sum(r["refused"] is None for r in rows)
    lines = [heading, f"{len(rows)} objects, {read} read, {len(rows) - read} not read", ""]
    lines.append(f"{'object':9s}  {'access':6s} {'type':14s} {'value':26s} {'SI':18s} name")
    for r in rows:
        start = f"{r['object']:9s}  {r['access']:6s} {r['type']:14s}"
        if r["refused"] is not None:
            lines.append(f"{start} {'(not read)':26s} {'':18s} {r['name']}: {r['refused']}")
            continue
        lines.append(f"{start} {_shown(r):26s} {_si(r['quantity']):18s} {r['name']}")
    return lines
