"""An SDO upload's answer against the type the EDS/DCF gives the object (CiA 301 data types).

canopen takes the first bytes of an answer longer than the type ("some devices send U32 even
if the variable is smaller") and raises its ``ObjectDictionaryError`` on a shorter one. Here an
answer whose size the device indicated must be the type's size; one that is longer only by
bytes that repeat its value's extension (zeros for an unsigned integer, the sign for a signed
one) is taken as that value, as canopen takes it. Any other size is ``DictionaryMismatch``: one
line naming the node, the object, the file, the declared type and the bytes received. An
expedited answer of unspecified size (4 bytes, CiA 301) is read as the type's first bytes.
"""

from __future__ import annotations

from typing import Any

from canopen.objectdictionary import SIGNED_TYPES, UNSIGNED_TYPES

from drivers.errors import DictionaryMismatch
from drivers.maps.eds_values import TYPE_NAMES

__all__ = ["sized"]

_SHOWN = 16  #: [bytes] of an answer shown in the message


def _padding(var: Any, data: bytes, size: int) -> bool:
    """The bytes past ``size`` only extend the value (zeros; the sign for a signed type)."""
    surplus = data[size:]
    if var.data_type in UNSIGNED_TYPES:
        return not any(surplus)
    if var.data_type in SIGNED_TYPES:
        fill = 0xFF if data[size - 1] & 0x80 else 0x00
        return all(b == fill for b in surplus)
    return False


def _bytes(n: int) -> str:
    return f"{n} byte" + "s" * (n != 1)


def sized(var: Any, data: bytes, indicated: int | None, *, node_id: int, source: str) -> bytes:
    """``data``, answered to an upload of canopen ``var`` (``indicated``: the size the device gave,
    None where it gave none), cut to ``var``'s type; DictionaryMismatch where it does not fit it.

    Parameters
    ----------
    var : Any
        The canopen variable uploaded.
    data : bytes
        The bytes answered.
    indicated : int | None
        The size the device gave (None: none).
    node_id : int
        The node, named in the error.
    source : str
        The dictionary's file, named in the error.

    Returns
    -------
    bytes
        ``data`` cut to the variable's size.

    Raises
    ------
    DictionaryMismatch
        If the answer is shorter than the type.
    """
    if not var.fixed_size:
        return data
    size = len(var) // 8
    if len(data) == size or (indicated is None and len(data) > size):
        return data[:size]
    if len(data) > size and _padding(var, data, size):
        return data[:size]
    shown = data[:_SHOWN].hex(" ") + (" ..." if len(data) > _SHOWN else "")
    kind = TYPE_NAMES.get(var.data_type, f"data type 0x{var.data_type:04X}")
    raise DictionaryMismatch(
        f"node {node_id}: 0x{var.index:04X}:{var.subindex:02X} ({var.name}) is {kind} ({_bytes(size)}) in "
        f"{source}, but the device answered {_bytes(len(data))} ({shown}): the EDS/DCF is not this "
        "device's; give the device's own"
    )
