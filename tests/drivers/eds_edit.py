"""Editing an EDS's text as a lab engineer's file may differ from the device: an object taken out,
one key's value changed (for the tests of dictionaries that lie)."""

from __future__ import annotations

import re

__all__ = ["object_indices", "with_value", "without"]


def without(text: str, *indices: int) -> str:
    """EDS ``text`` without the objects ``indices`` (their sections and their lines in the lists)."""
    pattern = "|".join(f"{i:04X}" for i in indices)
    sections = re.split(r"(?m)^(?=\[)", text)
    kept = [s for s in sections if not re.match(rf"\[({pattern})(sub[0-9A-Fa-f]+)?\]", s, re.IGNORECASE)]
    return re.sub(rf"(?m)^\d+=0x({pattern})\n", "", "".join(kept), flags=re.IGNORECASE)


def with_value(text: str, section: str, key: str, value: str) -> str:
    """EDS ``text`` with ``key`` of ``[section]`` (e.g. ``6085``, ``1800sub2``) set to ``value``."""
    changed, n = re.subn(rf"(?s)(\[{section}\][^\[]*?{key}=)[^\n]*", rf"\g<1>{value}", text)
    assert n == 1, (section, key)
    return changed


def object_indices(text: str) -> list[int]:
    """The indices of the objects of EDS ``text`` (its ``[XXXX]`` sections)."""
    return [int(m, 16) for m in re.findall(r"(?m)^\[([0-9A-Fa-f]{4})\]", text)]
