"""The run recorder: one directory per run, flushed as it goes, nothing lost on a stop.

``<output>/<name>-<YYYYmmdd-HHMMSS>/`` holds config.json, started.json, samples.csv (one row
per cycle, flushed every ``flush_period`` [s] of run time and on close), columns.json,
samples.mat, the CAN trace (``rig.host.run_trace``), summary.json and plot.png (docs/files.md).

The JSON files, ``samples.mat`` and ``plot.png`` are written whole or not at all (a
temporary file, then a rename); ``samples.csv`` and ``trace.asc`` end in a whole row and
line whatever the disk refused (``rig.host.storage``). A write that fails while the run goes
on (disk full, the directory removed) raises ``StorageError`` from ``sample``: the loop makes
it a safe stop. The close never raises: it writes what it can (a removed directory is made
again, the samples copied from the open file; space held since the start for the last rows
and the summary) and lists what it could not: ``files_not_written`` (each file missing or cut
short), ``samples_not_written`` (rows not in samples.csv) and the reasons under ``warnings``.

Nothing of the samples is held in memory during the run; the close reads them back in chunks
(``rig.host.readback``) for samples.mat and for the plot, which draws each column's minimum and
maximum over at most 4,000 buckets of rows: a run's memory does not grow with its length.

Frames reach ``on_frame`` from the bus's receive thread while the loop writes samples: a trace
that cannot be written is stopped, and the next ``sample`` raises its error.
"""

from __future__ import annotations

import datetime
import functools
import logging
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import can
import numpy as np

from drivers.errors import ConfigError, StorageError
from rig.host.readback import Columns, Envelope, copy_text, read_rows
from rig.host.run_plot import plot_run
from rig.host.run_trace import RunTrace
from rig.host.storage import (
    Reserve,
    RowFile,
    finite,
    json_writer,
    suppressed,
    write_atomic,
    write_mat,
)
from rig.live.backend import RowSink

__all__ = ["Recorder", "output_folder"]

log = logging.getLogger(__name__)


def output_folder(output: str | Path, where: str = "[run]") -> Path:
    """The folder ``output`` runs go to.

    Parameters
    ----------
    output : str | Path
        ``[run] output``.
    where : str
        The file and table, named in the error.

    Returns
    -------
    Path
        The folder (made by the first run, if need be).

    Raises
    ------
    ConfigError
        When it, or the nearest part of it that exists, is a file.
    """
    out = Path(output)
    for p in (out, *out.parents):
        if p.exists():
            if not p.is_dir():
                what = "is a file" if p == out else f"is below the file {p}"
                raise ConfigError(f"{where} output = {str(output)!r}: {what}, not a folder")
            break
    return out


class Recorder:
    """A fresh run directory under ``output``; ``begin(columns)``, then one ``sample`` per cycle.

    Parameters
    ----------
    output : str | Path
        ``[run] output``.
    name : str
        ``[run] name`` (checked at load: ``rig.config.checks.run_name``).
    flush_period : float
        [s] of run time (the rows' t) between flushes of samples.csv.
    trace : str | bool
        A key of ``rig.host.run_trace.TRACE_WRITERS`` or "none" (True and False: "asc" and "none").

    Raises
    ------
    ConfigError
        Where the run directory cannot be made, or would leave ``output``.
    """

    def __init__(
        self,
        output: str | Path,
        name: str,
        *,
        flush_period: float = 0.05,
        trace: str | bool = "asc",
    ) -> None:
        out = output_folder(output)  # the name was checked at load (rig.config.checks.run_name)
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        base = out / f"{name}-{stamp}"
        path, n = base, 1
        while path.exists():
            n += 1
            path = Path(f"{base}-{n}")
        if path.resolve().parent != out.resolve():  # its own guard: a run directory stays in output
            raise ConfigError(
                f"[run] name = {name!r}: the run directory {path} leaves output {str(output)!r}"
            )
        try:
            path.mkdir(parents=True)
        except OSError as exc:
            raise ConfigError(f"[run] output = {str(output)!r}: cannot make {path}: {exc.strerror}") from exc
        self.dir = path
        self._reserve = Reserve(path)  #: room for the close on a disk that fills up
        self.columns: list[str] = []
        self.docs: dict[str, dict[str, str]] = {}  #: column -> unit and meaning
        self._file = RowFile(path / "samples.csv")  # whole rows on disk; read back by ``_text``'s pread
        self._count = 0
        self._flush_period = flush_period  #: [s] of run time (the rows' t)
        self._flush_at = 0.0
        kind = ("asc" if trace else "none") if isinstance(trace, bool) else trace
        self.error: StorageError | None = None  #: a write that failed (raised by the next ``sample``)
        self._trace = RunTrace(path, kind, self._keep_error)
        #: the live view's rows (``rig.live.backend.Live.rows``: ``rig.live.view.Ring``, or the
        #: shared ring of ``rig run --view``, ``rig.live.shared_ring``): each written row is appended
        self.live: RowSink | None = None

    #: write plot.png on close when matplotlib is installed (the class's default; a run's own may
    #: differ: a sweep's point turns both off on its recorder)
    PLOT: bool = True
    #: fsync each file written whole (a sweep's point in a temporary folder turns it off)
    DURABLE: bool = True

    def begin(self, columns: Sequence[str], docs: dict[str, dict[str, str]] | None = None) -> None:
        """The samples' columns (known once the axes are set up): the CSV header.

        Parameters
        ----------
        columns : Sequence[str]
            The columns, in the rows' order.
        docs : dict[str, dict[str, str]] | None
            Column -> unit and meaning, for columns.json and samples.mat (None: none).
        """
        self.columns = list(columns)
        self.docs = docs or {}
        self._file.write(",".join(self.columns) + "\n")
        if self.docs:
            self._write_json("columns.json", self.docs)

    def write_config(self, config: dict[str, Any]) -> None:
        """Write config.json, whole.

        Parameters
        ----------
        config : dict[str, Any]
            The resolved configuration.
        """
        self._write_json("config.json", config)

    def mark_start(self) -> None:
        """Write ``started.json`` with the wall-clock time the cycles start (for post-mortems).

        Raises
        ------
        StorageError
            Where it cannot be written.
        """
        self._write_json("started.json", {"wall_time": time.time()})

    def _write_json(self, name: str, data: dict[str, Any]) -> None:
        try:
            write_atomic(self.dir / name, json_writer(data), sync=self.DURABLE)
        except OSError as exc:
            raise self._failed(name, exc) from exc

    def _failed(self, name: str, exc: OSError) -> StorageError:
        what = exc.strerror or str(exc)
        return StorageError(f"{self.dir / name}: {what}")

    def _keep_error(self, error: StorageError) -> None:
        """A write failed (the trace's): the next ``sample`` raises the first such error."""
        self.error = self.error or error
        log.error("%s", self.error)

    @property
    def trace(self) -> Any:
        """The trace's python-can writer (None: none, or stopped by a failed write)."""
        return self._trace.writer

    @property
    def closed(self) -> bool:
        """The close has begun: no frame is traced after it."""
        return self._trace.closed

    def on_frame(self, msg: can.Message) -> None:
        """A CAN frame for the trace (a bus listener, any thread); after the close it is counted.

        Parameters
        ----------
        msg : can.Message
            The frame.
        """
        self._trace.on_frame(msg)

    def sample(self, row: Sequence[float], timing: Sequence[float] = ()) -> None:
        """One cycle's row; the values at full precision (``repr``: they read back exactly).

        Parameters
        ----------
        row : Sequence[float]
            The values in ``columns`` order (``row[0]``: its time [s]).
        timing : Sequence[float]
            Its stage durations [s] (written in us, to 0.1 us).

        Raises
        ------
        StorageError
            When the run directory cannot be written (a failed flush or trace: at the next call; the
            row is kept for the close).
        """
        if self.error is not None:
            error, self.error = self.error, None
            raise error
        line = ",".join(map(repr, map(float, row)))
        if timing:
            line += self._timing_format(len(timing)) % tuple([d * 1e6 for d in timing])
        flush = row[0] >= self._flush_at
        if flush and not self.dir.is_dir():
            raise StorageError(f"{self.dir}: the run directory was removed")
        self._file.write(line + "\n")  # the row is kept: on disk now, at the close, or counted lost
        self._count += 1
        if flush:
            self._flush_at = row[0] + self._flush_period
            try:
                self._file.flush()
            except OSError as exc:  # raised by the next sample, as a trace's error
                self.error = self.error or self._failed("samples.csv", exc)
        if self.live is not None:  # an O(1) append, no lock: the live view reads it elsewhere
            self.live.append(row)

    @staticmethod
    @functools.cache
    def _timing_format(n: int) -> str:
        """``n`` stage durations [us] to 0.1 us, each after a comma (one format per row)."""
        return ",%.1f" * n

    @property
    def samples(self) -> int:
        """The rows written so far."""
        return self._count

    def _text(self, summary: dict[str, Any] | None = None) -> str:
        """Every whole line of samples.csv, read from the open file's descriptor (there even if
        the file's directory was removed; what a full disk refused stays out, and no seek
        retries its flush)."""
        f = self._file
        if not f.closed:
            with suppressed("samples.csv not flushed", summary):
                f.flush()
            chunks, offset = [], 0
            while chunk := os.pread(f.fileno(), 1 << 20, offset):
                chunks.append(chunk)
                offset += len(chunk)
            text = b"".join(chunks).decode("utf-8", errors="replace")
        else:
            text = (self.dir / "samples.csv").read_text()
        return text[: text.rfind("\n") + 1]  # a row torn by a full disk is no row

    def array(self, text: str | None = None) -> np.ndarray:
        """The samples read back (nothing is held in memory during the run).

        Parameters
        ----------
        text : str | None
            samples.csv's text (None: read from the open file).

        Returns
        -------
        np.ndarray
            Rows x columns.
        """
        if not self._count:
            return np.empty((0, len(self.columns)))
        lines = (self._text() if text is None else text).splitlines()[1 : self._count + 1]
        data = np.loadtxt(lines, delimiter=",", ndmin=2)
        return data.reshape(-1, len(self.columns))

    def close(self, summary: dict[str, Any]) -> None:
        """Flush everything, write .mat, the plot and summary.json; safe to call twice; never raises.

        What could not be written is listed under ``files_not_written`` and ``warnings`` and
        logged; ``samples_not_written`` counts the rows not in samples.csv.

        Parameters
        ----------
        summary : dict[str, Any]
            The run's summary, written to summary.json with what the close adds.
        """
        if self.closed:
            return
        summary["files_not_written"] = []
        self._trace.close(summary)
        self._reserve.shrink()  # room for the last rows, samples.mat and the plot; the rest: the summary
        with suppressed("samples.csv not flushed", summary):
            self._file.flush()
        fd = self._file.fileno()  # read back from the descriptor: there even if the directory is not
        if not self.dir.is_dir():  # removed during the run: made again, the samples with it
            self._remake(fd, summary)
        lost = self._count - max(self._file.lines - 1, 0)  # whole lines on disk, the header's too
        summary["samples_not_written"] = lost
        if lost:
            summary["files_not_written"].append("samples.csv")
            summary.setdefault("warnings", []).append(f"samples.csv: the last {lost} samples not written")
        envelope = self._read_back(fd, self._count - lost, summary)
        if self.PLOT:
            with suppressed("plot.png not written", summary, "plot.png"):
                self.plot(envelope.rows())
        self._reserve.release()
        with suppressed("summary.json not written", summary, "summary.json"):
            write_atomic(self.dir / "summary.json", json_writer(finite(summary)), sync=self.DURABLE)

    def _remake(self, fd: int, summary: dict[str, Any]) -> None:
        """The run directory removed during the run made again, samples.csv copied from ``fd``."""
        with suppressed("the run directory could not be made again", summary):
            self.dir.mkdir(parents=True)
            write_atomic(
                self.dir / "samples.csv", lambda f: copy_text(fd, f.write), binary=True, sync=self.DURABLE
            )
            summary.setdefault("warnings", []).append(
                f"{self.dir} was removed during the run: made again with samples.csv"
            )

    def _read_back(self, fd: int, rows: int, summary: dict[str, Any]) -> Envelope:
        """The ``rows`` on disk read back once (``fd``): samples.mat written, samples.csv closed;
        the plot's envelope."""
        envelope = Envelope(self._count, len(self.columns))
        with Columns(self._count, len(self.columns)) as columns:
            with suppressed("samples.csv not read back", summary):
                for chunk in read_rows(fd, len(self.columns), rows):
                    envelope.add(chunk)
                    columns.add(chunk)
            with suppressed("samples.csv not closed", summary):
                self._file.close()  # what the disk still refuses stays out, counted above
            with suppressed("samples.mat not written", summary, "samples.mat"):
                write_atomic(
                    self.dir / "samples.mat",
                    lambda f: self._write_mat(f, columns),
                    binary=True,
                    sync=self.DURABLE,
                )
        return envelope

    def _write_mat(self, f: Any, columns: Columns) -> None:
        write_mat(f, self.columns, columns.column, self.docs)

    def plot(self, data: np.ndarray) -> Any:
        """Write plot.png (``rig.host.run_plot``).

        Parameters
        ----------
        data : np.ndarray
            Rows of ``columns`` (at the close, the ``readback.Envelope`` of the run's).

        Returns
        -------
        Any
            The matplotlib figure; None without matplotlib or samples.
        """
        return plot_run(self.dir, data, self.columns, self.docs, durable=self.DURABLE)
