"""A progress line on stderr for what takes more than a moment: done of total, elapsed, remaining.

Only where stderr is a terminal and the output is not ``--json`` (a script reading stdout or a
log file gets nothing); redrawn at most ``rate`` times a second, so a 1 kHz loop pays a clock
read per update; ``close`` ends the line.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """``Progress(label, total, unit)``; ``update(done)`` with done of total; ``close()``.

    Parameters
    ----------
    label : str
        What is counted.
    total : float
        Of it.
    unit : str
        Its unit.
    json : bool, optional
        The output is ``--json``: nothing drawn.
    stream : TextIO | None, optional
        Where it writes (None: stderr).
    rate : float, optional
        [Hz] redraws at most.
    """

    def __init__(
        self,
        label: str,
        total: float,
        unit: str,
        *,
        json: bool = False,
        stream: TextIO | None = None,
        rate: float = 5.0,
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self._terminal = not json and self.stream.isatty()
        self.on = self._terminal and total > 0
        self.label, self.total, self.unit = label, total, unit
        self._start = time.monotonic()
        self._every = 1.0 / rate
        self._next = 0.0
        self._drawn = False

    def cycles(self, k: int, total: int) -> None:
        """``update`` for a run whose length is known once it is set up: ``k`` of ``total`` done.

        Parameters
        ----------
        k : int
            Cycles done.
        total : int
            Of the run.
        """
        if self.total != total:
            self.total = total
            self.on = self._terminal and total > 0
        self.update(k)

    def update(self, done: float, note: str = "") -> None:
        """``done`` of the total; ``note`` goes at the line's end (a rate, the failures).

        Parameters
        ----------
        done : float
            Of the total.
        note : str, optional
            At the line's end.
        """
        if not self.on:
            return
        now = time.monotonic()
        if now < self._next and done < self.total:
            return
        self._next = now + self._every
        elapsed = now - self._start
        fraction = min(max(done / self.total, 0.0), 1.0)
        remaining = f"{elapsed * (1.0 - fraction) / fraction:.0f} s left" if fraction > 0.0 else "-"
        unit = f" {self.unit}" if self.unit else ""
        self.stream.write(
            f"\r{self.label}: {done:,.0f}/{self.total:,.0f}{unit} ({100.0 * fraction:.0f} %), "
            f"{elapsed:.0f} s, {remaining}{', ' + note if note else ''}   "
        )
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """End the line drawn."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False
