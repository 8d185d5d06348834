"""A run's CAN trace file, written from the bus's receive thread while the loop writes samples.

The trace is python-can's ``ASCWriter`` (``rig.host.trace.AscTrace``: ``trace.asc``) or, with
``[run] trace = "blf"``, its ``BLFWriter`` (``trace.blf``, written in compressed blocks of up to
128 KiB, so a killed run loses the last block). A lock orders the frames against the close: a
frame that arrives after it is dropped and counted (``trace_frames_dropped`` in the summary),
never an exception in the receive thread; a trace that cannot be written is stopped, cut back to
its last whole line (``trace.asc``), and its error handed to the recorder, whose next ``sample``
raises it.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import can

from drivers.errors import StorageError
from rig.host.storage import suppressed, trim_to_line
from rig.host.trace import AscTrace

__all__ = ["TRACE_WRITERS", "RunTrace"]

log = logging.getLogger(__name__)

#: ``[run] trace`` -> the trace's file name and python-can writer (``"none"``: no trace)
TRACE_WRITERS: dict[str, tuple[str, Callable[[str], Any]]] = {
    "asc": ("trace.asc", AscTrace),
    "blf": ("trace.blf", can.BLFWriter),
}


class RunTrace:
    """The trace of the run directory ``folder`` (module docstring).

    Parameters
    ----------
    folder : Path
        The run directory.
    kind : str
        A key of ``TRACE_WRITERS``, or "none" (no trace: frames are ignored).
    failed : Callable[[StorageError], None]
        Takes the error of a write that failed.
    """

    def __init__(self, folder: Path, kind: str, failed: Callable[[StorageError], None]) -> None:
        self.dir = folder
        self.name, writer = ("", None) if kind == "none" else TRACE_WRITERS[kind]
        self.writer = writer(str(folder / self.name)) if writer is not None else None
        self.cut = ""  #: why the trace ends early (a write failed); "": it does not
        self.closed = False
        self.lock = threading.Lock()
        self.dropped = 0  #: frames that arrived after the close
        self._failed = failed

    def on_frame(self, msg: can.Message) -> None:
        """A CAN frame for the trace (a bus listener, any thread); after the close it is counted.

        Parameters
        ----------
        msg : can.Message
            The frame.
        """
        with self.lock:
            if self.writer is None:
                return
            if self.closed:
                self.dropped += 1
                return
            try:
                self.writer.on_message_received(msg)
            except Exception as exc:  # never into the bus's receive thread
                self._drop(exc)

    def _drop(self, exc: Exception) -> None:
        """The trace cannot be written: stop it; its error goes to ``failed``."""
        writer, self.writer = self.writer, None
        what = (exc.strerror or str(exc)) if isinstance(exc, OSError) else str(exc)
        self._failed(StorageError(f"{self.dir / self.name}: {what}"))
        self.cut = f"cut short: {exc}"
        try:
            if writer is not None:
                writer.file.close()
        except Exception as close_exc:
            log.debug("trace not closed: %s", close_exc)
        self._trim()

    def _trim(self) -> None:
        """trace.asc cut short by a failed write: its torn last line cut off (a BLF's blocks are
        not lines: BLFReader stops at a torn one by itself)."""
        if self.name != "trace.asc":
            return
        try:
            trim_to_line(self.dir / "trace.asc")
        except OSError as exc:
            log.debug("trace.asc not trimmed: %s", exc)

    def close(self, summary: dict[str, Any]) -> None:
        """Close the trace (no frame is written after it) and say in ``summary`` what cut it short.

        Parameters
        ----------
        summary : dict[str, Any]
            The run's summary: ``trace_frames_dropped``, and the trace under ``files_not_written``
            and ``warnings`` where it was cut short.
        """
        with self.lock:
            self.closed = True
            if self.writer is not None:
                with suppressed(f"{self.name} not closed", summary):
                    try:
                        self.writer.stop()
                    except Exception as exc:
                        self.cut = f"cut short at its close: {exc}"
                        self._trim()
                        raise
        if self.cut:
            summary["files_not_written"].append(self.name)
            summary.setdefault("warnings", []).append(f"{self.name} {self.cut}")
        summary["trace_frames_dropped"] = self.dropped
