"""A run's CAN trace as the view shows it (``rig.view.store.Store.trace``): python-can's reader
(ASC or BLF), frames filtered by COB-ID (``cob_filter``), a page at a time, each named by CiA 301's
predefined connection set (``frame_name``)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from rig.view.errors import ViewError

__all__ = ["MAX_IDS", "MAX_PAGE", "cob_filter", "frame_name", "trace_page"]

MAX_PAGE = 1000  #: trace frames a request may ask for at most
MAX_IDS = 64  #: terms of a COB-ID filter at most

#: CiA 301's predefined connection set: (first COB-ID, last, name; the node is the rest)
_FUNCTIONS = (
    (0x000, 0x000, "NMT"),
    (0x080, 0x080, "SYNC"),
    (0x081, 0x0FF, "EMCY"),
    (0x100, 0x100, "TIME"),
    (0x181, 0x1FF, "TPDO1"),
    (0x201, 0x27F, "RPDO1"),
    (0x281, 0x2FF, "TPDO2"),
    (0x301, 0x37F, "RPDO2"),
    (0x381, 0x3FF, "TPDO3"),
    (0x401, 0x47F, "RPDO3"),
    (0x481, 0x4FF, "TPDO4"),
    (0x501, 0x57F, "RPDO4"),
    (0x581, 0x5FF, "SDO tx"),
    (0x601, 0x67F, "SDO rx"),
    (0x701, 0x77F, "heartbeat"),
)


def frame_name(cob_id: int, extended: bool = False) -> str:
    """What CiA 301's predefined connection set calls ``cob_id`` ("TPDO1 node 1"), "" if nothing.

    Parameters
    ----------
    cob_id : int
        The COB-ID.
    extended : bool, optional
        A 29-bit identifier.

    Returns
    -------
    str
        The name, or "".
    """
    if extended:
        return ""
    for low, high, name in _FUNCTIONS:
        if low <= cob_id <= high:
            node = cob_id - (low & ~0x7F) if low != high else 0
            return f"{name} node {node}" if node else name
    return ""


_TERM = re.compile(r"^(?:0x)?([0-9a-f]{1,8})(?:-(?:0x)?([0-9a-f]{1,8}))?$")


def cob_filter(text: str) -> list[tuple[int, int]]:
    """``text`` ("181, 201", "0x180-0x1FF": hexadecimal COB-IDs and ranges, commas or spaces
    between) as ranges; ViewError 400 naming the term that is neither.

    Parameters
    ----------
    text : str
        COB-IDs and ranges in hex.

    Returns
    -------
    list[tuple[int, int]]
        (low, high) ranges.

    Raises
    ------
    ViewError
        400, if a term is neither.
    """
    terms = [t for t in re.split(r"[\s,]+", text.strip().lower()) if t]
    if len(terms) > MAX_IDS:
        raise ViewError(400, f"cob: {len(terms)} terms; at most {MAX_IDS}")
    ranges = []
    for term in terms:
        m = _TERM.match(term)
        if m is None:
            raise ViewError(400, f"cob: {term[:20]!r} is not a hexadecimal COB-ID or range (181, 180-1FF)")
        low = int(m.group(1), 16)
        high = int(m.group(2), 16) if m.group(2) else low
        ranges.append((min(low, high), max(low, high)))
    return ranges


def trace_page(
    file: Path, name: str, ranges: list[tuple[int, int]], first: int, count: int
) -> dict[str, Any]:
    """A page of the frames of trace ``file`` whose COB-ID is in ``ranges`` (all without): from the
    ``first``-th match, ``count`` of them, how many match in all and the frames of each COB-ID.

    Parameters
    ----------
    file : Path
        The trace (trace.asc or trace.blf).
    name : str
        The run's, named in an error.
    ranges : list[tuple[int, int]]
        (low, high) COB-IDs (``cob_filter``; empty: all).
    first : int
        The first match shown.
    count : int
        Matches shown at most.

    Returns
    -------
    dict[str, Any]
        The page.

    Raises
    ------
    ViewError
        422, if the file cannot be read at all.
    """
    import can

    frames: list[dict[str, Any]] = []
    seen: dict[int, int] = {}
    matched = 0
    try:
        for msg in can.LogReader(str(file)):
            cob_id = msg.arbitration_id
            if ranges and not any(lo <= cob_id <= hi for lo, hi in ranges):
                continue
            seen[cob_id] = seen.get(cob_id, 0) + 1
            if first <= matched < first + count:
                frames.append(
                    {
                        "t": msg.timestamp,
                        "cob_id": cob_id,
                        "extended": msg.is_extended_id,
                        "dir": "Rx" if msg.is_rx else "Tx",
                        "dlc": msg.dlc,
                        "data": bytes(msg.data).hex(" ").upper(),
                        "name": frame_name(cob_id, msg.is_extended_id),
                    }
                )
            matched += 1
    except Exception as exc:  # a trace cut short by a kill: what was read is shown
        if not frames and not matched:
            raise ViewError(422, f"run {name!r}: {file.name} cannot be read: {exc}") from exc
    ids = [{"cob_id": k, "name": frame_name(k), "frames": v} for k, v in sorted(seen.items())]
    return {"file": file.name, "matched": matched, "offset": first, "frames": frames, "ids": ids}
