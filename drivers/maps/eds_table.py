"""The table an EDS (CiA 306) is written from (``drivers.maps.eds_writer``): a list of ``Obj``,
each a VAR (``var``) or a RECORD/ARRAY of ``Var`` entries (``record``); the CiA 301 data types;
a PDO mapping entry (``mapped``); the file's [DeviceInfo] (``DeviceInfo``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from drivers.maps.pdo_entry import map_entry

__all__ = [
    "BOOLEAN",
    "INT8",
    "INT16",
    "INT32",
    "UINT8",
    "UINT16",
    "UINT32",
    "VSTRING",
    "DeviceInfo",
    "Obj",
    "Var",
    "mapped",
    "record",
    "var",
]

# CiA 301 data types
BOOLEAN, INT8, INT16, INT32, UINT8, UINT16, UINT32, VSTRING = 0x1, 0x2, 0x3, 0x4, 0x5, 0x6, 0x7, 0x9


@dataclass(frozen=True)
class Var:
    """One variable: name, type, access, default, PDO mappable."""

    name: str  #: the ParameterName
    data_type: int  #: its CiA 301 data type
    access: str = "rw"  #: ro, wo, rw or const
    default: str = "0"  #: the DefaultValue as written
    pdo: bool = False  #: PDO mappable


@dataclass(frozen=True)
class Obj:
    """One object: a VAR (one entry in ``subs`` at subindex 0) or a RECORD/ARRAY."""

    index: int  #: the object's index
    name: str  #: its ParameterName
    subs: tuple[tuple[int, Var], ...]  #: (subindex, variable) pairs
    #: 0x7 VAR, 0x8 ARRAY, 0x9 RECORD
    kind: int = 0x9  # 0x7 VAR, 0x8 ARRAY, 0x9 RECORD


@dataclass(frozen=True)
class DeviceInfo:
    """The [DeviceInfo] of an EDS."""

    vendor_name: str  #: VendorName
    vendor_number: int  #: VendorNumber (0x1018 sub 1)
    product_name: str  #: ProductName
    product_number: int  #: ProductNumber (0x1018 sub 2)
    description: str  #: the file's Description
    baud_rates: tuple[int, ...] = (125, 250, 500, 1000)  #: [kbit/s]
    lss: bool = False  #: it is an LSS slave (CiA 305: its node-ID and bit rate set over the bus)


def var(index: int, v: Var) -> Obj:
    """A VAR object.

    Parameters
    ----------
    index : int
        Its index.
    v : Var
        Its variable.

    Returns
    -------
    Obj
        The object.
    """
    return Obj(index, v.name, ((0, v),), 0x7)


def record(index: int, name: str, entries: Sequence[tuple[int, Var]], *, kind: int = 0x9) -> Obj:
    """A RECORD (or ARRAY) object, its sub 0 the highest subindex.

    Parameters
    ----------
    index : int
        Its index.
    name : str
        Its name.
    entries : Sequence[tuple[int, Var]]
        (subindex, variable) pairs.
    kind : int, optional
        0x9 RECORD or 0x8 ARRAY.

    Returns
    -------
    Obj
        The object.
    """
    highest = max(s for s, _ in entries)
    return Obj(
        index, name, ((0, Var("Highest sub-index supported", UINT8, "ro", str(highest))), *entries), kind
    )


def mapped(index: int, sub: int, bits: int) -> int:
    """A PDO mapping entry: index << 16 | subindex << 8 | bits.

    Parameters
    ----------
    index, sub : int
        The object mapped.
    bits : int
        Its size [bit].

    Returns
    -------
    int
        The mapping entry.
    """
    return map_entry(index, sub, bits)
