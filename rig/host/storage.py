"""What the recorder's files do when the disk fails: whole rows on disk, room kept for the summary.

``RowFile`` writes ``samples.csv``: the rows wait in memory between flushes and go to the
file with ``os.pwrite`` at the end of what is on disk. When the disk refuses part of a flush
(ENOSPC, EFBIG past a file-size limit, EIO, EROFS), the file is cut back to its last whole
row (``ftruncate``: no torn row stays on disk) and the rows not written are kept for a later
flush (the close, once ``Reserve`` has made room) and counted (``lines``).

``Reserve`` holds ``RESERVE`` bytes of the run directory's filesystem from the start
(``posix_fallocate`` on a file unlinked at once, so a killed host leaves nothing behind):
at the close it is shrunk to ``SUMMARY_ROOM`` for the last rows, ``samples.mat`` and
``plot.png``, then released for ``summary.json``, so a disk that filled up during the run
still takes the summary. Where the filesystem cannot allocate ahead, there is no reserve
and the close does what the disk allows.

``trim_to_line`` cuts a text file (``trace.asc``) that a failed write left with a torn last
line back to its last whole line. ``write_atomic`` writes a file whole or not at all (the JSON
files, ``samples.mat``, ``plot.png``), ``write_mat`` MATLAB's samples one column at a time.
``suppressed`` keeps the recorder's close going past what it cannot write, said in the summary.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "RESERVE",
    "SUMMARY_ROOM",
    "Reserve",
    "RowFile",
    "finite",
    "json_writer",
    "suppressed",
    "trim_to_line",
    "write_atomic",
    "write_mat",
]

log = logging.getLogger(__name__)

RESERVE = 256 * 1024  #: [bytes] held for the close: the last rows, samples.mat, plot.png, summary.json
SUMMARY_ROOM = 64 * 1024  #: [bytes] of it kept back for summary.json (about 1-10 KiB)


class RowFile:
    """``path`` opened for rows of text, whole rows on disk (module docstring).

    ``write`` keeps a row (ending in a newline), ``flush`` puts the rows kept on disk whole or raises
    OSError with the file cut back to its last whole row; ``fileno()`` reads back with ``os.pread``.

    Parameters
    ----------
    path : Path
        The file, created or truncated.
    """

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o666)
        self._rows: list[str] = []
        self._pending = b""  #: refused by the disk at the last flush, whole rows
        self.size = 0  #: [bytes] whole lines on disk
        self.lines = 0  #: whole lines on disk
        self.closed = False

    def write(self, text: str) -> None:
        """Keep ``text`` for the next flush.

        Parameters
        ----------
        text : str
            Whole lines.
        """
        self._rows.append(text)

    def fileno(self) -> int:
        """The file's descriptor (for ``os.pread``: its position is not used).

        Returns
        -------
        int
            The descriptor.
        """
        return self._fd

    @property
    def unwritten(self) -> int:
        """Lines kept but not on disk."""
        return self._pending.count(b"\n") + sum(r.count("\n") for r in self._rows)

    def flush(self) -> None:
        """Every line kept onto the disk, or OSError with the file ending in a whole line and
        the lines not written kept."""
        if self.closed or not (self._rows or self._pending):
            return
        data = self._pending + "".join(self._rows).encode("utf-8")
        self._rows.clear()
        done = 0
        try:
            while done < len(data):
                done += os.pwrite(self._fd, memoryview(data)[done:], self.size + done)
        except OSError:
            whole = data.rfind(b"\n", 0, done) + 1  # the last whole line written
            self._pending = data[whole:]
            self._keep(data[:whole])
            if whole < done:  # a torn line on disk: cut it off
                with contextlib.suppress(OSError):
                    os.ftruncate(self._fd, self.size)
            raise
        self._pending = b""
        self._keep(data)

    def _keep(self, written: bytes) -> None:
        self.size += len(written)
        self.lines += written.count(b"\n")

    def close(self) -> None:
        """Flush, then close (the descriptor is closed even when the flush raises)."""
        if self.closed:
            return
        try:
            self.flush()
        finally:
            self.closed = True
            os.close(self._fd)


class Reserve:
    """``size`` bytes held on the filesystem of ``folder`` until ``shrink`` and ``release``.

    Parameters
    ----------
    folder : Path
        The run directory.
    size : int
        [bytes] held (none where the filesystem cannot allocate ahead).
    """

    def __init__(self, folder: Path, size: int = RESERVE) -> None:
        self._fd: int | None = None
        path = folder / ".reserve"
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except OSError as exc:
            log.debug("no space reserved in %s: %s", folder, exc)
            return
        try:
            os.posix_fallocate(fd, 0, size)
        except (OSError, AttributeError) as exc:  # a full disk, a filesystem without it, not POSIX
            log.debug("no space reserved in %s: %s", folder, exc)
            os.close(fd)
            with contextlib.suppress(OSError):
                path.unlink()
            return
        try:
            path.unlink()  # the space stays held by the descriptor; nothing is left if we die
        except OSError:
            os.close(fd)
            return
        self._fd = fd

    @property
    def held(self) -> bool:
        """The space is held.

        Returns
        -------
        bool
            True where it was allocated and is not released.
        """
        return self._fd is not None

    def shrink(self, keep: int = SUMMARY_ROOM) -> None:
        """Give back all but ``keep`` bytes.

        Parameters
        ----------
        keep : int
            [bytes] still held.
        """
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.ftruncate(self._fd, keep)

    def release(self) -> None:
        """Give back the rest (idempotent)."""
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)


def trim_to_line(path: Path, block: int = 4096) -> None:
    """Cut ``path`` after its last newline (nothing when it ends in one); OSError if it cannot.

    Parameters
    ----------
    path : Path
        A text file.
    block : int
        [bytes] read at a time, backwards from the end.
    """
    with path.open("rb+") as f:
        end = f.seek(0, os.SEEK_END)
        pos = end
        while pos > 0:
            start = max(0, pos - block)
            f.seek(start)
            chunk = f.read(pos - start)
            cut = chunk.rfind(b"\n")
            if cut >= 0:
                if start + cut + 1 < end:
                    f.truncate(start + cut + 1)
                return
            pos = start
        f.truncate(0)


def write_atomic(
    path: Path, write: Callable[[Any], None], *, binary: bool = False, sync: bool = True
) -> None:
    """``write(file)`` into a temporary file beside ``path``, then rename it to ``path``.

    The file is there whole or not at all (OSError when it cannot be written).

    Parameters
    ----------
    path : Path
        The file written.
    write : Callable[[Any], None]
        Writes the content into the open file it is given.
    binary : bool
        Open it in binary mode.
    sync : bool
        On the disk (fsync) before the rename.
    """
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        with tmp.open("wb" if binary else "w") as f:
            write(f)
            f.flush()
            if sync:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_mat(
    f: Any, names: Sequence[str], column: Callable[[int], np.ndarray], docs: dict[str, dict[str, str]]
) -> None:
    """samples.mat into ``f``, one column in memory at a time.

    One variable per column, then the structs column_unit and column_meaning (MATLAB:
    column_unit.t = 's'), each appended in turn.

    Parameters
    ----------
    f : Any
        The binary file, open.
    names : Sequence[str]
        The columns' names (dots written as underscores).
    column : Callable[[int], np.ndarray]
        Column ``i``'s samples.
    docs : dict[str, dict[str, str]]
        Each column's ``unit`` and ``meaning`` (``describe_columns``).
    """
    import scipy.io

    for i, name in enumerate(c.replace(".", "_") for c in names):
        scipy.io.savemat(f, {name: column(i)})
    for key in ("unit", "meaning"):
        structs = {c.replace(".", "_"): d[key] for c, d in docs.items()}
        scipy.io.savemat(f, {f"column_{key}": structs})


def finite(value: Any) -> Any:
    """``value`` with every non-finite float, nested ones too, as None (JSON has no NaN).

    Parameters
    ----------
    value : Any
        A float, or a dict, list or tuple of them (others are kept as they are).

    Returns
    -------
    Any
        The same, NaN and infinities as None.
    """
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    return value


def json_writer(data: dict[str, Any]) -> Callable[[Any], None]:
    """What writes ``data`` as indented JSON into a text file (for `write_atomic`).

    Parameters
    ----------
    data : dict[str, Any]
        The object.

    Returns
    -------
    Callable[[Any], None]
        Writes it into the open file it is given.
    """
    return lambda f: f.write(json.dumps(data, indent=2) + "\n")


@contextlib.contextmanager
def suppressed(what: str, summary: dict[str, Any] | None = None, file: str = "") -> Iterator[None]:
    """An exception inside is logged and said in the summary; the close goes on.

    Parameters
    ----------
    what : str
        What failed, in words.
    summary : dict[str, Any] | None
        The run's summary: ``what`` and the exception go under its ``warnings`` (None: logged only).
    file : str
        A file not written, listed under its ``files_not_written`` ("": none).

    Yields
    ------
    None
        The block run.
    """
    try:
        yield
    except Exception as exc:
        log.error("%s: %s", what, exc)
        if summary is not None:
            summary.setdefault("warnings", []).append(f"{what}: {exc}")
            if file:
                summary.setdefault("files_not_written", []).append(file)
