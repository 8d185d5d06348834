"""A PDO mapping entry (CiA 301: sub 1-8 of 0x1600/0x1A00 + n): the object mapped and its size in
one UNSIGNED32."""

from __future__ import annotations

__all__ = ["map_entry", "split_map_entry"]


def map_entry(index: int, subindex: int, bits: int) -> int:
    """A PDO mapping entry (sub 1-8 of 0x1600/0x1A00 + n): index << 16 | subindex << 8 | bits.

    Parameters
    ----------
    index, subindex : int
        The object mapped.
    bits : int
        Its size [bit].

    Returns
    -------
    int
        The entry.
    """
    return index << 16 | subindex << 8 | bits


def split_map_entry(entry: int) -> tuple[int, int, int]:
    """(index, subindex, bits) of a PDO mapping entry.

    Parameters
    ----------
    entry : int
        A PDO mapping entry.

    Returns
    -------
    tuple[int, int, int]
        (index, subindex, bits).
    """
    return entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
