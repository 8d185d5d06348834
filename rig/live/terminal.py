"""The live view as a compact strip on stderr: a header with the run's time, then one line per
axis with its reference, measurement and command (with units) and a sparkline of |error| over
the latest rows. On a terminal the block is redrawn in place; elsewhere (a log file, a pipe)
a plain block at most once a second and the last values at the end, without escape codes.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import TextIO

from rig.live.channels import Channel

__all__ = ["ASCII", "BLOCKS", "TerminalStrip", "sparkline", "strip_lines"]

BLOCKS = "▁▂▃▄▅▆▇█"  #: the sparkline's levels, lowest first
ASCII = " .:-=+*#"  #: the same where the stream cannot write BLOCKS
SAMPLED = 256  #: rows the sparkline looks at, at most (every k-th of the latest)


def sparkline(values: Sequence[float], width: int = 16, blocks: str = BLOCKS) -> str:
    """``values`` (>= 0) in ``width`` bins (each its largest value), as ``blocks`` scaled to the
    largest of all; "" for no values, the lowest block where all are 0 or not finite.

    Parameters
    ----------
    values : Sequence[float]
        Values >= 0.
    width : int, optional
        Bins.
    blocks : str, optional
        The characters, lowest first.

    Returns
    -------
    str
        The sparkline.
    """
    if not values:
        return ""
    n = min(width, len(values))
    top = max((v for v in values if math.isfinite(v)), default=0.0)
    out = []
    for b in range(n):
        chunk = values[b * len(values) // n : (b + 1) * len(values) // n]
        v = max((x for x in chunk if math.isfinite(x)), default=0.0)
        level = 0 if top <= 0.0 else min(len(blocks) - 1, int(v / top * (len(blocks) - 1) + 0.5))
        out.append(blocks[level])
    return "".join(out)


def _field(label: str, value: float | None, unit: str, width: int) -> str:
    text = "-" if value is None else f"{value:.5g}"
    return f"{label} {text:>10s} {unit:<{width}s}"


def strip_lines(
    channels: Sequence[Channel], rows: Sequence[Sequence[float]], *, spark: int = 16, blocks: str = BLOCKS
) -> list[str]:
    """The strip for the latest ``rows`` (oldest first; ``row[0]``: time [s]): a header, then per
    channel ``ref``, ``meas``, ``cmd`` of the last row with their units and, where the axis has a
    reference, ``|e|``: a sparkline of |reference - measurement| over ``rows`` (every k-th, at most
    ``SAMPLED``) and the largest of them.

    Parameters
    ----------
    channels : Sequence[Channel]
        The axes shown.
    rows : Sequence[Sequence[float]]
        The latest rows, oldest first.
    spark : int, optional
        The sparkline's width.
    blocks : str, optional
        Its characters.

    Returns
    -------
    list[str]
        The strip's lines.
    """
    last = rows[-1] if rows else None
    header = f"live  t = {last[0]:.3f} s" if last is not None else "live  waiting for the first cycle"
    name_w = max((len(c.axis) for c in channels), default=0)
    unit_w = max((len(u) for c in channels for u in c.units), default=0)
    lines = [header]
    for c in channels:
        values = [None if i is None or last is None else last[i] for i in c.columns]
        parts = [f"  {c.axis:<{name_w}s}"]
        parts += [_field(k, v, u, unit_w) for k, v, u in zip(("ref", "meas", "cmd"), values, c.units)]
        if c.reference is not None and c.measurement is not None and rows:
            errors = [abs(r[c.reference] - r[c.measurement]) for r in rows[:: 1 + len(rows) // SAMPLED]]
            finite = [e for e in errors if math.isfinite(e)]
            peak = max(finite, default=math.nan)
            parts.append(f"|e| {sparkline(errors, spark, blocks)} max {peak:.3g} {c.units[1]}".rstrip())
        lines.append("  ".join(parts).rstrip())
    return lines


class TerminalStrip:
    """The strip as a live-view backend (``rig.live.view``) on ``stream`` (default stderr).

    Parameters
    ----------
    stream : TextIO | None, optional
        Where it writes (None: stderr).
    plain_every : float, optional
        [s] between plain writes where ``stream`` is no terminal.
    """

    def __init__(self, stream: TextIO | None = None, *, plain_every: float = 1.0) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.plain_every = plain_every  #: [s] between two plain blocks where not a terminal
        self.channels: list[Channel] = []
        self._shown = 0  #: lines of the block on screen (a terminal)
        self._next = 0.0  #: time.monotonic() [s] of the next plain block
        encoding = getattr(self.stream, "encoding", None) or "ascii"
        try:
            BLOCKS.encode(encoding)
            self.blocks = BLOCKS
        except (UnicodeEncodeError, LookupError):
            self.blocks = ASCII

    def open(self, channels: Sequence[Channel], title: str) -> None:
        """Begin the strip of ``channels`` under ``title``.

        Parameters
        ----------
        channels : Sequence[Channel]
            The axes shown.
        title : str
            The run's name.
        """
        self.channels = list(channels)
        self.title = title

    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        """Redraw the block in place (a terminal), or write it plain when due or ``final``.

        Parameters
        ----------
        rows : Sequence[Sequence[float]]
            The latest rows, oldest first.
        final : bool, optional
            The run has ended.
        """
        lines = strip_lines(self.channels, rows, blocks=self.blocks)
        if self.tty:
            up = f"\x1b[{self._shown}F" if self._shown else ""
            self.stream.write(up + "".join(f"\x1b[2K{line}\n" for line in lines))
            self._shown = len(lines)
        else:
            now = time.monotonic()
            if not final and (now < self._next or not rows):
                return
            self._next = now + self.plain_every
            self.stream.write("\n".join(lines) + "\n")
        self.stream.flush()

    def close(self) -> None:
        """End the strip (its last block stays on the terminal)."""
        self._shown = 0
