"""The values an EDS/DCF gives its objects (DefaultValue, ParameterValue), read as CiA 306 writes them,
and the types it gives the objects CiA makes integers (``check_types``).

canopen's parser leaves a value it cannot read as None without a word: a drive built
from such a file (the emulator's) then aborts every read of the object, and a host that
reads the file goes on with nothing. ``check_values`` reads every numeric value again and
refuses one it cannot read, naming the file, the object, the key and the value:

- an integer type (and BOOLEAN): decimal, hexadecimal (``0x1F``), octal (a leading 0, as
  CiA 306 has it), with a sign; ``$NODEID`` as one term of a sum is the node id
  (``$NODEID+0x180``, ``0x180+$NODEID``, ``$NODEID``);
- a signed type given in hexadecimal with its top bit set is its two's complement
  (``0xFFFF`` as INTEGER16 is -1), as canopen reads LowLimit/HighLimit;
- REAL32/REAL64: a decimal number, or a hexadecimal integer that is its IEEE 754 bit pattern
  (``0x40200000`` as REAL32 is 2.5), as some vendors' tools write them;
- the value must fit its type.

An empty value is no value (the file gives none). Strings, OCTET_STRING and DOMAIN are not
numbers and are not checked here. A value canopen could not read but this module can
(``$NODEID`` alone, an octal, a two's complement, a REAL's bit pattern) is set on the object.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Iterator
from typing import Any

from canopen.objectdictionary import BOOLEAN, FLOAT_TYPES, INTEGER_TYPES, REAL32, SIGNED_TYPES

from drivers.errors import ConfigError

__all__ = ["INTEGER_OBJECTS", "TYPE_NAMES", "check_types", "check_values", "parse_value", "variables"]

#: the objects CiA 301 and CiA 402 give an integer type (each entry of a record or an array too),
#: of the ranges the toolkit and its emulated devices read and write: device type .. sync window,
#: guarding, store/restore .. verify configuration, error behaviour, SDO and PDO parameters;
#: abort connection option, 0x603F .. 0x60FF, supported drive modes (0x1008-0x100A, 0x6503-0x6505
#: are strings, 0x1F50 a domain: not among them)
INTEGER_OBJECTS = (
    range(0x1000, 0x1008), range(0x100C, 0x100E), range(0x1010, 0x1021), range(0x1029, 0x102A),
    range(0x1200, 0x1300), range(0x1400, 0x1C00), range(0x6007, 0x6008), range(0x603F, 0x6100),
    range(0x6502, 0x6503),
)  # fmt: skip

#: CiA 301's names of the data types (0x0001-0x001B), for messages
TYPE_NAMES = {
    0x01: "BOOLEAN", 0x02: "INTEGER8", 0x03: "INTEGER16", 0x04: "INTEGER32", 0x05: "UNSIGNED8",
    0x06: "UNSIGNED16", 0x07: "UNSIGNED32", 0x08: "REAL32", 0x09: "VISIBLE_STRING",
    0x0A: "OCTET_STRING", 0x0B: "UNICODE_STRING", 0x0C: "TIME_OF_DAY", 0x0D: "TIME_DIFFERENCE",
    0x0F: "DOMAIN", 0x10: "INTEGER24", 0x11: "REAL64", 0x12: "INTEGER40", 0x13: "INTEGER48",
    0x14: "INTEGER56", 0x15: "INTEGER64", 0x16: "UNSIGNED24", 0x18: "UNSIGNED40", 0x19: "UNSIGNED48",
    0x1A: "UNSIGNED56", 0x1B: "UNSIGNED64",
}  # fmt: skip

#: the keys of an object's section that hold a value, and canopen's attribute of each
_KEYS = (("DefaultValue", "default_raw", "default"), ("ParameterValue", "value_raw", "value"))
_INTEGER = re.compile(r"[+-]?(0[xX][0-9a-fA-F]+|0[0-7]*|[1-9][0-9]*)")
_NODEID = "$NODEID"
_NUMERIC = frozenset((BOOLEAN, *INTEGER_TYPES, *FLOAT_TYPES))


def variables(od: Any) -> Iterator[Any]:
    """Every variable of canopen object dictionary ``od`` (records' and arrays' entries too).

    Parameters
    ----------
    od : Any
        A canopen object dictionary.

    Yields
    ------
    Iterator[Any]
        Its variables, records' and arrays' entries included.
    """
    for obj in od.values():
        if hasattr(obj, "subindices"):
            yield from obj.values()
        else:
            yield obj


def _integer(term: str) -> int:
    if not _INTEGER.fullmatch(term):
        raise ValueError(f"{term!r} is not a number (decimal, 0x hexadecimal or 0 octal)")
    sign = -1 if term[0] == "-" else 1
    digits = term.lstrip("+-")
    if digits[:2].lower() == "0x":
        return sign * int(digits, 16)
    return sign * int(digits, 8 if len(digits) > 1 and digits[0] == "0" else 10)


def _sum(text: str, node_id: int) -> tuple[int, bool]:
    """(the value of a sum of integer terms and ``$NODEID``, whether a term was hexadecimal)."""
    terms = text.removeprefix("+").split("+")  # a leading "+" is a sign, not a sum's
    if text.count(_NODEID) > 1:
        raise ValueError(f"{_NODEID} more than once")
    total, hexadecimal = 0, False
    for term in terms:
        if term == _NODEID:
            total += node_id
        else:
            total += _integer(term)
            hexadecimal |= "0x" in term.lower()
    return total, hexadecimal


def parse_value(text: str, data_type: int, node_id: int) -> int | float:
    """The value ``text`` of an object of CiA 301 ``data_type`` (see the module docstring);
    ValueError saying why it is not one.

    Parameters
    ----------
    text : str
        A DefaultValue or ParameterValue as written.
    data_type : int
        Its CiA 301 data type.
    node_id : int
        The node, for ``$NODEID``.

    Returns
    -------
    int | float
        The value.

    Raises
    ------
    ValueError
        If ``text`` is not a value of that type (why said).
    """
    t = "".join(text.split())
    if _NODEID.lower() in t.lower() and _NODEID not in t:
        t = re.sub(re.escape(_NODEID), _NODEID, t, flags=re.IGNORECASE)
    if data_type in FLOAT_TYPES:
        fmt = "<f" if data_type == REAL32 else "<d"
        if t.lower().startswith(("0x", "+0x", "-0x")) and _NODEID not in t:
            bits = _integer(t)
            size = struct.calcsize(fmt)
            if not 0 <= bits < 1 << (8 * size):
                raise ValueError(f"a bit pattern of {8 * size} bits is 0x0 .. 0x{(1 << 8 * size) - 1:X}")
            return float(struct.unpack(fmt, bits.to_bytes(size, "little"))[0])
        try:
            return float(t)
        except ValueError:
            raise ValueError("not a number") from None
    value, hexadecimal = _sum(t, node_id)
    bits = 1 if data_type == BOOLEAN else _bits(data_type)
    if data_type in SIGNED_TYPES:
        low, high = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
        if hexadecimal and high < value < 1 << bits:
            value -= 1 << bits  # two's complement, as written in hexadecimal
    else:
        low, high = 0, (1 << bits) - 1
    if not low <= value <= high:
        raise ValueError(f"{value} does not fit the type ({low} .. {high})")
    return value


def _bits(data_type: int) -> int:
    from canopen.objectdictionary import ODVariable

    return 8 * int(ODVariable.STRUCT_TYPES[data_type].size)


def check_values(od: Any, source: str, node_id: int) -> None:
    """Read every numeric DefaultValue and ParameterValue of ``od`` (parsed by canopen from
    ``source``, for ``node_id``) again; ConfigError naming file, object, key and value.

    Parameters
    ----------
    od : Any
        The dictionary canopen parsed.
    source : str
        Its file, named in the error.
    node_id : int
        The node it was parsed for.

    Raises
    ------
    ConfigError
        At a numeric value that does not read (file, object, key and value named).
    """
    for var in variables(od):
        if var.data_type not in _NUMERIC:
            continue
        for key, raw_attr, attr in _KEYS:
            raw = getattr(var, raw_attr, None)
            if raw is None or not str(raw).strip():
                continue
            try:
                value = parse_value(str(raw), var.data_type, node_id)
            except ValueError as exc:
                raise ConfigError(
                    f"{source}: object 0x{var.index:04X}:{var.subindex:02X} ({var.name}): "
                    f"{key}={raw}: {exc}; correct the value in the file (CiA 306)"
                ) from None
            setattr(var, attr, value)


def check_types(od: Any, source: str) -> None:
    """ConfigError naming the file, the object and its type where ``od`` declares an object of
    ``INTEGER_OBJECTS`` with another type (a string, a REAL, a domain): the host reads it as an
    integer and an emulated device writes one to it.

    Parameters
    ----------
    od : Any
        The dictionary canopen parsed.
    source : str
        Its file, named in the error.

    Raises
    ------
    ConfigError
        If an object of ``INTEGER_OBJECTS`` has another type.
    """
    for var in variables(od):
        if var.data_type not in INTEGER_TYPES and any(var.index in r for r in INTEGER_OBJECTS):
            kind = TYPE_NAMES.get(var.data_type, f"data type 0x{var.data_type:04X}")
            raise ConfigError(
                f"{source}: object 0x{var.index:04X}:{var.subindex:02X} ({var.name}) is {kind} in the file; "
                "CiA 301/402 make it an integer: correct its DataType, or give the device's own EDS/DCF"
            )
