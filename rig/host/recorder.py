"""The run recorder: one directory per run, flushed as it goes, nothing lost on a stop.

Contents of ``<output>/<name>-<YYYYmmdd-HHMMSS>/``:

- ``config.json``: the resolved configuration;
- ``started.json``: the wall-clock time the cycles started;
- ``samples.csv``: one row per cycle (time, reference, measurement, command,
  controller internals, loop timing), flushed every ``flush_period`` [s] of run time
  and on close;
- ``samples.mat``: the same columns for MATLAB (scipy.io.savemat), written on close;
- ``trace.asc``: the CAN trace in Vector ASCII (python-can's ``ASCWriter``), which
  CANalyzer, SavvyCAN, asammdf and python-can read; ``trace.blf`` instead with
  ``[run] trace = "blf"`` (python-can's ``BLFWriter``: Vector's binary logging format, which
  CANoe, CANalyzer and asammdf open; it is written in compressed blocks of up to 128 KiB, so a
  killed run loses the last block); left out with ``trace = "none"``;
- ``summary.json``: the metrics and how the run ended;
- ``plot.png`` when matplotlib is installed (and ``Recorder.PLOT``, which the tests turn off
  but in the test of the plot itself): reference and measurement, and the command, titled with
  the run's name, the axes labelled with their units.

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

Frames reach ``on_frame`` from the bus's receive thread (python-can's notifier)
while the loop writes samples; a lock orders the trace against ``close``, and a
frame that arrives after the close is dropped and counted
(``trace_frames_dropped`` in the summary), never an exception in that thread: a
trace that cannot be written is stopped, and the next ``sample`` raises its error.
"""

from __future__ import annotations

import collections
import contextlib
import datetime
import functools
import json
import logging
import math
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import can
import numpy as np

from drivers.errors import ConfigError, StorageError
from rig.host.readback import Columns, Envelope, copy_text, read_rows
from rig.host.storage import Reserve, RowFile, trim_to_line, write_atomic, write_mat
from rig.host.trace import AscTrace

#: ``[run] trace`` -> the trace's file name and python-can writer (``"none"``: no trace)
TRACE_WRITERS: dict[str, tuple[str, Callable[[str], Any]]] = {
    "asc": ("trace.asc", AscTrace),
    "blf": ("trace.blf", can.BLFWriter),
}

__all__ = ["TRACE_WRITERS", "Recorder", "output_folder"]

log = logging.getLogger(__name__)


def _finite(value: Any) -> Any:
    """``value`` with every non-finite float, nested ones too, as None (JSON has no NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def _json(data: dict[str, Any]) -> Callable[[Any], None]:
    return lambda f: f.write(json.dumps(data, indent=2) + "\n")


def output_folder(output: str | Path, where: str = "[run]") -> Path:
    """The folder ``output`` runs go to; ConfigError (``where``: the file and table) when it (or
    the nearest part of it that exists) is a file."""
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
    ``trace``: a key of ``TRACE_WRITERS`` or "none" (True and False: "asc" and "none")."""

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
        self.trace_name, writer = ("", None) if kind == "none" else TRACE_WRITERS[kind]
        self.trace = writer(str(path / self.trace_name)) if writer is not None else None
        self._trace_cut = ""  #: why the trace ends early (a write failed); "": it does not
        self.closed = False
        self._trace_lock = threading.Lock()
        self.frames_dropped = 0  #: frames that arrived after the close
        self.error: StorageError | None = None  #: a write that failed (raised by the next ``sample``)
        #: the live view's rows (``rig.live.view.LiveView.rows``): each written row is appended
        self.live: collections.deque[Sequence[float]] | None = None

    #: write plot.png on close when matplotlib is installed (the class's default; a run's own may
    #: differ: a sweep's point turns both off on its recorder)
    PLOT: bool = True
    #: fsync each file written whole (a sweep's point in a temporary folder turns it off)
    DURABLE: bool = True

    def begin(self, columns: Sequence[str], docs: dict[str, dict[str, str]] | None = None) -> None:
        """The samples' columns (known once the axes are set up): the CSV header; ``docs``
        (column -> unit and meaning) go to columns.json and into samples.mat."""
        self.columns = list(columns)
        self.docs = docs or {}
        self._file.write(",".join(self.columns) + "\n")
        if self.docs:
            self._write_json("columns.json", self.docs)

    def write_config(self, config: dict[str, Any]) -> None:
        self._write_json("config.json", config)

    def mark_start(self) -> None:
        """Write ``started.json`` with the wall-clock time the cycles start (for post-mortems)."""
        self._write_json("started.json", {"wall_time": time.time()})

    def _write_json(self, name: str, data: dict[str, Any]) -> None:
        try:
            write_atomic(self.dir / name, _json(data), sync=self.DURABLE)
        except OSError as exc:
            raise self._failed(name, exc) from exc

    def _failed(self, name: str, exc: OSError) -> StorageError:
        what = exc.strerror or str(exc)
        return StorageError(f"{self.dir / name}: {what}")

    def on_frame(self, msg: can.Message) -> None:
        """A CAN frame for the trace (a bus listener, any thread); after the close it is counted."""
        with self._trace_lock:
            if self.trace is None:
                return
            if self.closed:
                self.frames_dropped += 1
                return
            try:
                self.trace.on_message_received(msg)
            except Exception as exc:  # never into the bus's receive thread
                self._drop_trace(exc)

    def _drop_trace(self, exc: Exception) -> None:
        """The trace cannot be written: stop it; the next ``sample`` raises the error."""
        trace, self.trace = self.trace, None
        error = self._failed(self.trace_name, exc) if isinstance(exc, OSError) else None
        self.error = self.error or error or StorageError(f"{self.dir / self.trace_name}: {exc}")
        self._trace_cut = f"cut short: {exc}"
        log.error("%s", self.error)
        try:
            if trace is not None:
                trace.file.close()
        except Exception as close_exc:
            log.debug("trace not closed: %s", close_exc)
        self._trim_trace()

    def _trim_trace(self) -> None:
        """trace.asc cut short by a failed write: its torn last line cut off (a BLF's blocks are
        not lines: BLFReader stops at a torn one by itself)."""
        if self.trace_name != "trace.asc":
            return
        try:
            trim_to_line(self.dir / "trace.asc")
        except OSError as exc:
            log.debug("trace.asc not trimmed: %s", exc)

    def sample(self, row: Sequence[float], timing: Sequence[float] = ()) -> None:
        """One cycle's values in ``columns`` order (``row[0]``: its time [s]), then its stage
        durations [s] (written in us, to 0.1 us); the values at full precision (``repr``: they
        read back exactly). StorageError when the run directory cannot be written (a failed
        flush: at the next call; the row is kept for the close)."""
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
        if self.live is not None:  # an O(1) append, no lock: the live view copies it at a few Hz
            self.live.append(row)

    @staticmethod
    @functools.cache
    def _timing_format(n: int) -> str:
        """``n`` stage durations [us] to 0.1 us, each after a comma (one format per row)."""
        return ",%.1f" * n

    @property
    def samples(self) -> int:
        return self._count

    def _text(self, summary: dict[str, Any] | None = None) -> str:
        """Every whole line of samples.csv, read from the open file's descriptor (there even if
        the file's directory was removed; what a full disk refused stays out, and no seek
        retries its flush)."""
        f = self._file
        if not f.closed:
            with _suppressed("samples.csv not flushed", summary):
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
        """The samples read back (nothing is held in memory during the run), from samples.csv's
        ``text`` if given."""
        if not self._count:
            return np.empty((0, len(self.columns)))
        lines = (self._text() if text is None else text).splitlines()[1 : self._count + 1]
        data = np.loadtxt(lines, delimiter=",", ndmin=2)
        return data.reshape(-1, len(self.columns))

    def close(self, summary: dict[str, Any]) -> None:
        """Flush everything, write .mat, the plot and summary.json; safe to call twice; never
        raises (what could not be written is listed under ``files_not_written`` and
        ``warnings`` and logged; ``samples_not_written`` counts the rows not in samples.csv)."""
        if self.closed:
            return
        summary["files_not_written"] = []
        with self._trace_lock:
            self.closed = True
            if self.trace is not None:
                with _suppressed(f"{self.trace_name} not closed", summary):
                    try:
                        self.trace.stop()
                    except Exception as exc:
                        self._trace_cut = f"cut short at its close: {exc}"
                        self._trim_trace()
                        raise
        if self._trace_cut:
            summary["files_not_written"].append(self.trace_name)
            summary.setdefault("warnings", []).append(f"{self.trace_name} {self._trace_cut}")
        summary["trace_frames_dropped"] = self.frames_dropped
        self._reserve.shrink()  # room for the last rows, samples.mat and the plot; the rest: the summary
        with _suppressed("samples.csv not flushed", summary):
            self._file.flush()
        fd = self._file.fileno()  # read back from the descriptor: there even if the directory is not
        if not self.dir.is_dir():  # removed during the run: made again, the samples with it
            with _suppressed("the run directory could not be made again", summary):
                self.dir.mkdir(parents=True)
                write_atomic(
                    self.dir / "samples.csv", lambda f: copy_text(fd, f.write), binary=True, sync=self.DURABLE
                )
                summary.setdefault("warnings", []).append(
                    f"{self.dir} was removed during the run: made again with samples.csv"
                )
        lost = self._count - max(self._file.lines - 1, 0)  # whole lines on disk, the header's too
        summary["samples_not_written"] = lost
        if lost:
            summary["files_not_written"].append("samples.csv")
            summary.setdefault("warnings", []).append(f"samples.csv: the last {lost} samples not written")
        envelope = Envelope(self._count, len(self.columns))
        with Columns(self._count, len(self.columns)) as columns:
            with _suppressed("samples.csv not read back", summary):
                for chunk in read_rows(fd, len(self.columns), self._count - lost):
                    envelope.add(chunk)
                    columns.add(chunk)
            with _suppressed("samples.csv not closed", summary):
                self._file.close()  # what the disk still refuses stays out, counted above
            with _suppressed("samples.mat not written", summary, "samples.mat"):
                write_atomic(
                    self.dir / "samples.mat",
                    lambda f: self._write_mat(f, columns),
                    binary=True,
                    sync=self.DURABLE,
                )
        if self.PLOT:
            with _suppressed("plot.png not written", summary, "plot.png"):
                self.plot(envelope.rows())
        self._reserve.release()
        with _suppressed("summary.json not written", summary, "summary.json"):
            write_atomic(self.dir / "summary.json", _json(_finite(summary)), sync=self.DURABLE)

    def _write_mat(self, f: Any, columns: Columns) -> None:
        write_mat(f, self.columns, columns.column, self.docs)

    def _label(self, column: str, name: str) -> str:
        """``name [unit]`` with the column's unit from ``docs`` (none for a replay's mixed units)."""
        unit = self.docs.get(column, {}).get("unit", "")
        return f"{name} [{unit}]" if unit else name

    def plot(self, data: np.ndarray) -> Any:
        """Write plot.png from the samples ``data`` (rows of ``columns``; at the close, the
        ``readback.Envelope`` of the run's); returns the figure, None without matplotlib or samples.
        matplotlib's Figure without pyplot: no global state (a sweep's worker may run points in
        threads) and no pyplot to import."""
        try:
            from matplotlib.figure import Figure
        except ImportError:
            return None
        if not len(data):
            return None
        fig = Figure(figsize=(8, 6))
        axes = fig.subplots(2, 1, sharex=True)
        t = data[:, 0]
        for name in ("reference", "measurement"):
            axes[0].plot(t, data[:, self.columns.index(name)], label=name)
        axes[1].plot(t, data[:, self.columns.index("command")], label="command (first commanded axis)")
        axes[0].set_title("controlled variable")
        axes[0].set_ylabel(self._label("measurement", "reference, measurement"))
        axes[1].set_title("command")
        axes[1].set_ylabel(self._label("command", "command"))
        for ax in axes:
            ax.grid(True)
            ax.legend()
        axes[-1].set_xlabel("time [s]")
        fig.suptitle(f"run {self.dir.name}")
        fig.tight_layout()
        write_atomic(
            self.dir / "plot.png", lambda f: fig.savefig(f, format="png"), binary=True, sync=self.DURABLE
        )
        return fig


@contextlib.contextmanager
def _suppressed(what: str, summary: dict[str, Any] | None = None, file: str = "") -> Iterator[None]:
    """An exception inside is logged and, with a summary, listed under its ``warnings`` (and
    ``file`` under its ``files_not_written``); the close goes on."""
    try:
        yield
    except Exception as exc:
        log.error("%s: %s", what, exc)
        if summary is not None:
            summary.setdefault("warnings", []).append(f"{what}: {exc}")
            if file:
                summary.setdefault("files_not_written", []).append(file)
