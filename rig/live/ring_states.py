"""The axes' states in a shared ring's rows (``rig.live.shared_ring``): written by the loop from
what it already has, read and told in words by the reader's process.

Per axis, two columns after the recorder's row: the statusword 0x6041 of the axis's last TPDO
(NaN where the axis has none mapped, or none came yet), decoded from the frame the loop's own
feedback decoded this cycle (``TpdoSlot.values``: its cache, no new decode), and its fault's
number (0: none). A fault is an object the driver keeps (``AxisDriver.fault``: an EMCY's); a new
one (rare: a fault ends the run) gets the next number and its text in the axis's block of the
ring before the row that names it is published. The reader turns a row's columns into the
scope's ``{"state", "fault", "statusword"}``: CiA 402's power state where there is a statusword,
else "fault" or "running" (the protocol reports no more in its cycle).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from drivers.cia402_cycle import power_state
from drivers.maps.cia import STATUSWORD

__all__ = ["StateColumns", "state_words"]


def _where(axis: Any) -> tuple[Any, int] | None:
    """(the TPDO slot, the place) of ``axis``'s statusword, or None (no CiA 402 process data)."""
    where = getattr(getattr(axis, "data", None), "where", None)
    return None if where is None else where((STATUSWORD, 0))


class StateColumns:
    """The state columns of ``axes``, now (called by the ring's writer, on the loop's thread).

    Parameters
    ----------
    axes : Sequence[Any]
        The axes (``drivers.base.AxisDriver``), set up and enabled (their mapping in force).
    texts : Any
        Where the fault texts go (``rig.live.shared_ring.FaultTexts``).
    """

    def __init__(self, axes: Sequence[Any], texts: Any) -> None:
        #: per axis: its place, itself, its statusword's TPDO slot and place in it (None: none)
        self._probes = [(i, a, *(_where(a) or (None, 0))) for i, a in enumerate(axes)]
        self._texts = texts
        self._faults: list[Any] = [None] * len(self._probes)  #: the last fault object seen
        self._numbers = [0] * len(self._probes)
        self._count = 0

    def now(self) -> list[float]:
        """(statusword, fault number) per axis.

        Returns
        -------
        list[float]
            Two floats per axis.
        """
        out: list[float] = []
        for i, axis, slot, place in self._probes:
            word = math.nan
            if slot is not None and slot.timestamp is not None:
                try:
                    word = slot.values()[place]
                except Exception:  # a frame of the wrong length: the loop's own read says so
                    pass
            fault = axis.fault
            if fault is not self._faults[i]:  # rare: a new fault (or its clearing)
                self._new_fault(i, fault)
            out.append(word)
            out.append(self._numbers[i])
        return out

    def _new_fault(self, i: int, fault: Any) -> None:
        """Axis ``i``'s fault is now ``fault`` (None: cleared): its number, and its text first."""
        self._faults[i] = fault
        if fault is None:
            self._numbers[i] = 0
            return
        self._count += 1
        self._texts.write(i, self._count, str(fault))
        self._numbers[i] = self._count


def state_words(columns: Sequence[float], names: Sequence[str], texts: Any) -> dict[str, dict[str, Any]]:
    """The scope's states of the axes ``names`` from a row's state ``columns``.

    Parameters
    ----------
    columns : Sequence[float]
        The row's state columns (two per axis).
    names : Sequence[str]
        The axes' names.
    texts : Any
        The ring's fault texts (``rig.live.shared_ring.FaultTexts``).

    Returns
    -------
    dict[str, dict[str, Any]]
        Axis -> {"state", "fault", "statusword"}.
    """
    states: dict[str, dict[str, Any]] = {}
    for i, name in enumerate(names):
        word_f, number = columns[2 * i], int(columns[2 * i + 1])
        word = None if math.isnan(word_f) else int(word_f)
        fault = None if number == 0 else (texts.read(i, number) or "fault")
        if word is not None:
            state = power_state(word).value
        else:
            state = "fault" if fault is not None else "running"
        states[name] = {"state": state, "fault": fault, "statusword": word}
    return states
