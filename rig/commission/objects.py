"""One object of a drive for a person: how it is written on the command line (``parse_object``)
what an SDO read of it shows (``read_object``) and its name in the EDS (``object_name``): ``rig drive
sdo read/write``."""

from __future__ import annotations

from typing import Any

from drivers.cia402 import Cia402Axis
from drivers.cia402_pdo import variable
from drivers.errors import ConfigError
from drivers.identity import STANDARD
from drivers.maps.eds_values import TYPE_NAMES
from drivers.maps.logical import axis_object
from rig.commission.quantities import quantity

__all__ = ["object_name", "parse_object", "read_object"]


def parse_object(text: str, od: Any) -> tuple[int, int]:
    """``0x6060``, ``0x1018:01``, ``6060sub0`` or an EDS name (``Modes of operation``,
    ``Identity object.Vendor-ID``) -> (index, subindex); ConfigError naming ``text``. Index and
    sub-index are hexadecimal, ``0x`` or not, as an EDS and this toolkit's own output write them
    (``0x1A00:10`` is sub-index 16).

    Parameters
    ----------
    text : str
        The object as given.
    od : Any
        The drive's EDS.

    Returns
    -------
    tuple[int, int]
        (index, subindex).

    Raises
    ------
    ConfigError
        If ``text`` names no object (it named).
    """
    t = text.strip()
    index_text, _, sub_text = t.replace("sub", ":").partition(":")
    try:
        index = int(index_text, 16)
        sub = int(sub_text, 16) if sub_text else 0
    except ValueError:
        name, _, sub_name = t.partition(".")
        if name not in od:
            raise ConfigError(f"object {text!r}: neither index[:sub] nor a name in the EDS") from None
        obj = od[name]
        if not sub_name:
            return obj.index, 0
        if not hasattr(obj, "names") or sub_name not in obj.names:
            raise ConfigError(f"object {text!r}: {name!r} has no entry {sub_name!r}") from None
        return obj.index, obj[sub_name].subindex
    if not 0 <= index <= 0xFFFF or not 0 <= sub <= 0xFF:
        raise ConfigError(f"object {text!r}: index 0..0xFFFF, sub-index 0..255")
    return index, sub


def read_object(axis: Cia402Axis, index: int, subindex: int) -> dict[str, Any]:
    """One object read by SDO, for a person (nothing written).

    Parameters
    ----------
    axis : Cia402Axis
        The drive, set up or not.
    index, subindex : int
        The object.

    Returns
    -------
    dict[str, Any]
        Its name, type and access in the EDS, its value in decimal and hex, and where it holds
        a quantity (``rig.commission.quantities``), that in SI and in the drive's units (the
        units read from the drive).
    """
    a = axis
    value = a.sdo_read(index, subindex)
    var = variable(a.node.object_dictionary, (index, subindex))
    kind = getattr(var, "data_type", None)
    fmt = var.STRUCT_TYPES.get(kind) if var is not None and kind is not None else None
    size, type_name = (
        (fmt.size if fmt is not None else 4),
        TYPE_NAMES.get(kind, "") if kind is not None else "",
    )
    standard = STANDARD.get((index, subindex))
    if isinstance(value, bytes) and standard is not None and len(value) == standard[1]:
        signed, size = standard  # not in the EDS in use: by its standard's type (CiA 301/402)
        value = int.from_bytes(value, "little", signed=signed)
        type_name = f"{'INTEGER' if signed else 'UNSIGNED'}{8 * size} (CiA)"
    out: dict[str, Any] = {
        "object": f"0x{axis_object(index, a.axis_number):04X}:{subindex:02X}",  # on the wire: axis N's
        "name": str(var.name) if var is not None else "",
        "type": type_name,
        "access": str(getattr(var, "access_type", "")),
        "value": value if not isinstance(value, bytes) else value.hex(),
    }
    if isinstance(value, int) and not isinstance(value, bool):
        bits = 8 * size
        out["hex"] = f"0x{value & ((1 << bits) - 1):0{bits // 4}X}"
        q = quantity(a.discover(check_mode=False), index, value)
        if q is not None:
            out["quantity"] = q.as_dict()
    return out


def object_name(a: Cia402Axis, index: int, subindex: int) -> str:
    """An object's name in the drive's EDS, by its index on the wire ("" where it has none).

    Parameters
    ----------
    a : Cia402Axis
        The drive.
    index, subindex : int
        The object.

    Returns
    -------
    str
        Its name.
    """
    od = a.node.object_dictionary
    var = variable(getattr(od, "device", od), (index, subindex))
    return str(var.name) if var is not None else ""
