"""A ring of rows in memory shared with another process: one writer (the control loop, through
``Recorder.sample``), readers elsewhere that never make it wait (``rig run --view``: the view's
server process reads it, ``rig.view.ring_reader``). What TwinCAT Scope and ros2_control's
realtime_tools do: the real-time side writes into a lock-free buffer, the reader is elsewhere.

The memory is a ``memfd`` (Linux; an unlinked temporary file elsewhere): it has no name, so
nothing is left behind however either process ends (an exception, a signal, SIGKILL); it is
handed to the reader as a file descriptor over the view's pipe and freed when the last process
holding it unmaps it.

Layout (``Layout``): a header of int64 (``[0]``: the rows published so far, ever), one fault
text block per axis, then ``keep`` rows of float64, each the recorder's row followed by two
columns per axis, written by the loop from what it has: the statusword of the axis's last TPDO
(NaN: none) and its fault's number (0: none; its text in the axis's block, ``FaultTexts``).

The single writer's ``append`` writes the row into slot ``n % keep``, then publishes ``n + 1``
in the header: an O(1) row write (``struct.pack_into`` straight into the mapping) and one store,
no lock, no system call. A reader (``RingReader.read``) reads the count, copies the rows since its
last read, reads the count again (``after``) and keeps only the rows from ``after - keep + 1`` on:
the writer's next row, ``after``, goes into the slot of row ``after - keep``, and it may already
be writing it. A seqlock whose writer never retries and whose reader never waits; the reader
counts what it lost.

Why it holds: (1) CPython executes the row's bytes into the mapping before the count's store,
and the reader's first count before its copy and its second after (program order; each is a
fresh load of the mapped memory, nothing cached); (2) the count is one aligned 8-byte store and
load (a numpy int64 item), which x86-64 and ARM64 make whole, never half old and half new; (3)
x86-64 (total store order) makes one core's stores visible to another in the order they were
made and does not reorder loads with loads, so a reader that sees the count ``n`` sees row
``n - 1`` whole. On a weakly ordered CPU (ARM64) Python has no fence to give, and a reader may
rarely see a slot before its new values: each row carries its own number (column 0), which the
reader checks, so a slot seen stale is dropped; a row seen half-updated there is not caught.
"""

from __future__ import annotations

import logging
import mmap
import os
import struct
import tempfile
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["FaultTexts", "Layout", "RingReader", "SharedRing", "map_ring"]

log = logging.getLogger(__name__)

HEADER = 8  #: int64 words of the header ([0]: rows published)
TEXT = 256  #: bytes of one axis's fault text block (two int64, then the text)


class Layout:
    """Where things are in the shared memory of ``keep`` rows of ``width`` (the recorder's row)
    and ``axes`` axes.

    Parameters
    ----------
    keep : int
        Rows kept.
    width : int
        Floats of the recorder's row.
    axes : int
        Axes whose state columns follow the row.
    """

    def __init__(self, keep: int, width: int, axes: int) -> None:
        self.keep, self.width, self.axes = keep, width, axes
        self.columns = 1 + width + 2 * axes  #: the row's number, the row, then (statusword, fault)
        self.texts = HEADER * 8  #: offset of the fault text blocks
        self.rows = self.texts + TEXT * axes  #: offset of the rows
        self.size = self.rows + 8 * keep * self.columns  #: [bytes]

    def args(self) -> tuple[int, int, int]:
        """(keep, width, axes): what a reader needs to map the same layout.

        Returns
        -------
        tuple[int, int, int]
            The layout's parameters.
        """
        return self.keep, self.width, self.axes


def map_ring(fd: int, layout: Layout) -> tuple[mmap.mmap, np.ndarray, np.ndarray]:
    """Map ``fd`` as ``layout``: (the mapping, the header's int64, the rows' float64).

    Parameters
    ----------
    fd : int
        The shared memory's file descriptor (closed by the caller; the mapping stays).
    layout : Layout
        Its layout.

    Returns
    -------
    tuple[mmap.mmap, np.ndarray, np.ndarray]
        The mapping, the header, the rows.
    """
    buf = mmap.mmap(fd, layout.size)
    header = np.frombuffer(buf, dtype=np.int64, count=HEADER)
    rows = np.frombuffer(buf, dtype=np.float64, offset=layout.rows).reshape(layout.keep, layout.columns)
    return buf, header, rows


def _memory(size: int) -> int:
    """A file descriptor of ``size`` bytes of memory with no name (zeros)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("rig-view-ring", os.MFD_CLOEXEC)
    else:  # an unlinked temporary file: no name either
        with tempfile.TemporaryFile() as f:
            fd = os.dup(f.fileno())
    os.ftruncate(fd, size)
    return fd


class FaultTexts:
    """The axes' fault text blocks of a mapping: (the fault's number, its length, its text).

    Parameters
    ----------
    buf : mmap.mmap
        The mapping.
    layout : Layout
        Its layout.
    """

    def __init__(self, buf: mmap.mmap, layout: Layout) -> None:
        self._buf, self._at = buf, layout.texts
        self._words = [
            np.frombuffer(buf, dtype=np.int64, count=2, offset=layout.texts + TEXT * i)
            for i in range(layout.axes)
        ]

    def write(self, axis: int, number: int, text: str) -> None:
        """Axis ``axis``'s fault ``number`` is ``text`` (cut to the block): the text, then the number.

        Parameters
        ----------
        axis : int
            The axis's place.
        number : int
            The fault's number (1, 2, ...).
        text : str
            What it says.
        """
        data = text.encode("utf-8", "replace")[: TEXT - 16]
        at = self._at + TEXT * axis + 16
        self._buf[at : at + len(data)] = data
        self._words[axis][1] = len(data)
        self._words[axis][0] = number

    def read(self, axis: int, number: int) -> str | None:
        """Axis ``axis``'s fault ``number``'s text; None when the block holds another (being rewritten).

        Parameters
        ----------
        axis : int
            The axis's place.
        number : int
            The fault's number.

        Returns
        -------
        str | None
            Its text.
        """
        words = self._words[axis]
        if int(words[0]) != number:
            return None
        at = self._at + TEXT * axis + 16
        text = bytes(self._buf[at : at + min(int(words[1]), TEXT - 16)]).decode("utf-8", "replace")
        return text if int(words[0]) == number else None


class SharedRing:
    """The writer: ``keep`` rows of ``width`` floats and the state columns of ``axes`` (their
    statuswords and faults, ``rig.live.ring_states.StateColumns``), in shared memory.

    Parameters
    ----------
    keep : int
        Rows kept.
    width : int
        Floats of the recorder's row (``Recorder.sample``'s, without the stage times).
    axes : Sequence[Any]
        The axes (``drivers.base.AxisDriver``) whose states follow each row.
    """

    def __init__(self, keep: int, width: int, axes: Sequence[Any] = ()) -> None:
        from rig.live.ring_states import StateColumns

        self.layout = Layout(keep, width, len(axes))
        self.fd: int | None = _memory(self.layout.size)  #: for the reader, until ``close_fd``
        self._buf, self._header, self._rows = map_ring(self.fd, self.layout)
        self.texts = FaultTexts(self._buf, self.layout)
        self._states = StateColumns(axes, self.texts)
        self._n = 0
        self._keep = keep
        #: a row's bytes straight into the mapping (twice as fast as numpy's from a sequence)
        self._pack = struct.Struct(f"<{self.layout.columns}d").pack_into
        self._stride = 8 * self.layout.columns
        self.failed: str | None = None  #: why it stopped taking rows (a row of another width)

    def append(self, row: Sequence[float]) -> None:
        """Write ``row`` (the loop's, once a cycle) and its axes' states, then publish it. A row
        it cannot take ends the ring (``failed``), never the run.

        Parameters
        ----------
        row : Sequence[float]
            The recorder's row.
        """
        if self.failed is not None:
            return
        n = self._n
        try:
            self._pack(
                self._buf, self.layout.rows + (n % self._keep) * self._stride, n, *row, *self._states.now()
            )
        except (struct.error, TypeError) as exc:
            self.failed = f"a row of {len(row)} values, the ring's are {self.layout.width}: {exc}"
            log.warning("the live view's ring takes no more rows: %s (the run goes on)", self.failed)
            return
        self._n = n = n + 1
        self._header[0] = n  # after the row: a reader that sees n sees row n - 1 whole

    @property
    def published(self) -> int:
        """Rows appended so far."""
        return self._n

    def close_fd(self) -> None:
        """Close the descriptor (the reader has its own; the mapping goes when nothing refers to it,
        numpy's views included)."""
        fd, self.fd = self.fd, None
        if fd is not None:
            os.close(fd)


class RingReader:
    """A reader of a ``SharedRing`` in any process: ``read()`` gives the rows published since its
    last read that were not overwritten meanwhile, oldest first, and how many it lost.

    Parameters
    ----------
    fd : int
        The ring's file descriptor (``SharedRing.fd``, or one passed over a pipe); closed here.
    layout : Layout
        The ring's layout.
    """

    def __init__(self, fd: int, layout: Layout) -> None:
        self.layout = layout
        try:
            self._buf, self._header, self._rows = map_ring(fd, layout)
        finally:
            os.close(fd)
        self.texts = FaultTexts(self._buf, layout)
        self.next = 0  #: the number of the next row to read
        self.lost = 0  #: rows overwritten before they were read, in all

    def read(self) -> tuple[np.ndarray, int]:
        """The new rows (row number first, then the recorder's row, then the state columns) and
        how many rows were lost since the last read (overwritten before this one copied them).

        Returns
        -------
        tuple[np.ndarray, int]
            (rows, lost).
        """
        keep = self.layout.keep
        end = int(self._header[0])  # the count first: rows below it are whole
        start = max(self.next, end - keep)
        idx = np.arange(start, end) % keep
        rows = self._rows[idx]  # a copy (fancy indexing)
        after = int(self._header[0])  # then again: the writer may have reached some slots
        first = max(start, after - keep + 1)  # row j's slot is row j + keep's once that is begun
        rows = rows[first - start :]
        rows = rows[rows[:, 0] == np.arange(first, end)]  # each row's own number (see above)
        lost = (end - self.next - len(rows)) if end > self.next else 0
        self.next = max(self.next, end)
        self.lost += lost
        return rows, lost
