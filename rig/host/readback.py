"""A run's samples read back at its close, in chunks: memory that does not grow with the run.

The recorder holds nothing of the samples while the run goes on; at the close it reads
``samples.csv`` back once, a chunk of rows at a time, for two things:

- the plot, from ``Envelope``: the minimum and the maximum of every column over buckets of
  consecutive rows, at most ``POINTS`` buckets, so a chattering command still shows its band
  (a stride would pick one side of it);
- ``samples.mat``, from ``Columns``: the rows written column by column into an unnamed
  temporary file, then one column at a time into the MAT file (scipy.io.savemat appends each
  variable to the open file).

The memory is then a chunk of rows, the envelope and one column of samples.mat (8 bytes a
cycle, while scipy writes it), instead of the whole text and its table (about 400 bytes a cycle
with 20 columns).
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable, Iterator
from typing import IO, Any

import numpy as np

__all__ = ["POINTS", "Columns", "Envelope", "copy_text", "read_rows"]

#: the plot's buckets at most (each drawn as its minimum and maximum)
POINTS = 4000
#: [B] read from the file at a time
BLOCK = 1 << 20


def _blocks(fd: int) -> Iterator[bytes]:
    """The file open as ``fd`` from its start, ``BLOCK`` bytes at a time (``os.pread``: the
    descriptor's own position, where the recorder writes, is not moved)."""
    offset = 0
    while block := os.pread(fd, BLOCK, offset):
        offset += len(block)
        yield block


def copy_text(fd: int, write: Callable[[bytes], Any]) -> None:
    """Every whole line of the file open as ``fd`` to ``write``, a block at a time.

    A row torn by a full disk is left out.

    Parameters
    ----------
    fd : int
        The file's descriptor (read with ``os.pread``).
    write : Callable[[bytes], Any]
        Takes the lines, whole.
    """
    tail = b""
    for block in _blocks(fd):
        text = tail + block
        end = text.rfind(b"\n") + 1
        if end:
            write(text[:end])
        tail = text[end:]  # no line end yet (at the file's end: a torn row)


def read_rows(fd: int, columns: int, count: int, rows: int = 8192) -> Iterator[np.ndarray]:
    """The first ``count`` rows under the header of the CSV file open as ``fd``, in arrays.

    A torn last line is no row.

    Parameters
    ----------
    fd : int
        The file's descriptor (read with ``os.pread``).
    columns : int
        The columns of a row.
    count : int
        The rows read at most.
    rows : int
        The rows of an array (the last one shorter).

    Yields
    ------
    np.ndarray
        ``rows`` x ``columns``.
    """
    pending: list[bytes] = []
    left, tail, header = count, b"", True
    for block in _blocks(fd):
        lines = (tail + block).split(b"\n")
        tail = lines.pop()  # unfinished: it waits for the next block
        if header and lines:
            lines, header = lines[1:], False
        lines = lines[:left]
        left -= len(lines)
        pending.extend(lines)
        while len(pending) >= rows:
            yield _parse(pending[:rows], columns)
            del pending[:rows]
        if left <= 0:
            break
    if pending:
        yield _parse(pending, columns)


def _parse(lines: list[bytes], columns: int) -> np.ndarray:
    text = b"\n".join(lines).decode("utf-8", errors="replace")
    return np.loadtxt(text.splitlines(), delimiter=",", ndmin=2).reshape(-1, columns)


class Envelope:
    """The minimum and maximum of each column over buckets of ``ceil(count / points)`` rows.

    Parameters
    ----------
    count : int
        The rows to come.
    columns : int
        Their columns.
    points : int
        The buckets at most.
    """

    def __init__(self, count: int, columns: int, points: int = POINTS) -> None:
        self.size = max(1, math.ceil(count / points))
        self._parts: list[np.ndarray] = []
        self._carry = np.empty((0, columns))  #: the rows of a bucket a chunk ended in

    def add(self, chunk: np.ndarray) -> None:
        """The next rows.

        Parameters
        ----------
        chunk : np.ndarray
            Rows x columns.
        """
        rows = np.concatenate([self._carry, chunk]) if len(self._carry) else chunk
        whole = len(rows) - len(rows) % self.size
        self._carry = rows[whole:].copy()
        if whole:
            self._parts.append(_reduce(rows[:whole], self.size))

    def rows(self) -> np.ndarray:
        """Two rows per bucket, or the rows themselves where there are no more than ``points``.

        Returns
        -------
        np.ndarray
            Each bucket's minima, then its maxima (the first column, the time, is the bucket's first).
        """
        parts = [*self._parts, _reduce(self._carry, len(self._carry))] if len(self._carry) else self._parts
        return np.concatenate(parts) if parts else self._carry


def _reduce(rows: np.ndarray, size: int) -> np.ndarray:
    """Buckets of ``size`` rows as their minima and maxima (``Envelope``); the rows if ``size`` is 1."""
    if size == 1:
        return rows.copy()
    buckets = rows.reshape(-1, size, rows.shape[1])
    low, high = buckets.min(axis=1), buckets.max(axis=1)
    low[:, 0] = high[:, 0] = buckets[:, 0, 0]
    return np.stack([low, high], axis=1).reshape(-1, rows.shape[1])


class Columns:
    """Rows stored column by column in an unnamed temporary file, then read back a column at a time.

    ``close()`` (or a ``with``) removes it.

    Parameters
    ----------
    count : int
        The rows at most.
    columns : int
        Their columns.
    """

    def __init__(self, count: int, columns: int) -> None:
        self.count, self.n = count, 0
        self._file: IO[bytes] = tempfile.TemporaryFile(buffering=0)  # a write fails in add, not at close
        self.columns = columns

    def add(self, chunk: np.ndarray) -> None:
        """The next rows (OSError where the file cannot take them).

        Parameters
        ----------
        chunk : np.ndarray
            Rows x columns.
        """
        for c in range(self.columns):
            self._file.seek((c * self.count + self.n) * 8)
            self._file.write(np.ascontiguousarray(chunk[:, c], dtype="<f8").tobytes())
        self.n += len(chunk)

    def column(self, c: int) -> np.ndarray:
        """Column ``c`` of the rows added.

        Parameters
        ----------
        c : int
            Its index.

        Returns
        -------
        np.ndarray
            Its samples.
        """
        self._file.seek(c * self.count * 8)
        return np.frombuffer(self._file.read(self.n * 8), dtype="<f8")

    def close(self) -> None:
        """Remove the file."""
        self._file.close()

    def __enter__(self) -> Columns:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
