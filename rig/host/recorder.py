"""The run recorder: one directory per run, flushed as it goes, nothing lost on a stop.

Contents of ``<output>/<name>-<YYYYmmdd-HHMMSS>/``:

- ``config.json``: the resolved configuration;
- ``started.json``: the wall-clock time the cycles started;
- ``samples.csv``: one row per cycle (time, reference, measurement, command,
  controller internals, loop timing), flushed every ``flush_every`` rows and on close;
- ``samples.mat``: the same columns for MATLAB (scipy.io.savemat), written on close;
- ``trace.asc``: the CAN trace in Vector ASCII (python-can's ``ASCWriter``), which
  CANalyzer, SavvyCAN, asammdf and python-can read; left out with ``[run] trace = false``;
- ``summary.json``: the metrics and how the run ended;
- ``plot.png`` when matplotlib is installed.

Frames reach ``on_frame`` from the bus's receive thread (python-can's notifier)
while the loop writes samples; a lock orders the trace against ``close``, and a
frame that arrives after the close is dropped and counted
(``trace_frames_dropped`` in the summary), never an exception in that thread.
"""

from __future__ import annotations

import datetime
import json
import math
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import can
import numpy as np

from rig.host.trace import AscTrace

__all__ = ["Recorder"]


class Recorder:
    """A fresh run directory under ``output``; ``begin(columns)``, then one ``sample`` per cycle."""

    def __init__(
        self,
        output: str | Path,
        name: str,
        *,
        flush_every: int = 100,
        trace: bool = True,
    ) -> None:
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        base = Path(output) / f"{name}-{stamp}"
        path, n = base, 1
        while path.exists():
            n += 1
            path = Path(f"{base}-{n}")
        path.mkdir(parents=True)
        self.dir = path
        self.columns: list[str] = []
        self._file = (path / "samples.csv").open("w", newline="")
        self._count = 0
        self._flush_every = flush_every
        self._pending = 0
        self.trace = AscTrace(str(path / "trace.asc")) if trace else None
        self.closed = False
        self._trace_lock = threading.Lock()
        self.frames_dropped = 0  #: frames that arrived after the close

    def begin(self, columns: Sequence[str]) -> None:
        """The samples' columns (known once the axes are set up): the CSV header."""
        self.columns = list(columns)
        self._file.write(",".join(self.columns) + "\n")

    def write_config(self, config: dict[str, Any]) -> None:
        (self.dir / "config.json").write_text(json.dumps(config, indent=2) + "\n")

    def mark_start(self) -> None:
        """Write ``started.json`` with the wall-clock time the cycles start (for post-mortems)."""
        (self.dir / "started.json").write_text(json.dumps({"wall_time": time.time()}) + "\n")

    def on_frame(self, msg: can.Message) -> None:
        """A CAN frame for the trace (a bus listener, any thread); after the close it is counted."""
        with self._trace_lock:
            if self.trace is None:
                return
            if self.closed:
                self.frames_dropped += 1
                return
            self.trace.on_message_received(msg)

    def sample(self, row: Sequence[float], timing: Sequence[float] = ()) -> None:
        """One cycle's values in ``columns`` order, then its stage durations [s] (written in us,
        to 0.1 us); the values at full precision (``repr``: they read back exactly)."""
        line = ",".join(map(repr, map(float, row)))
        if timing:
            line += "," + ",".join(["%.1f" % (d * 1e6) for d in timing])
        self._file.write(line + "\n")
        self._count += 1
        self._pending += 1
        if self._pending >= self._flush_every:
            self._file.flush()
            self._pending = 0

    @property
    def samples(self) -> int:
        return self._count

    def array(self) -> np.ndarray:
        """The samples read back from samples.csv (nothing is held in memory during the run)."""
        if not self._count:
            return np.empty((0, len(self.columns)))
        if not self._file.closed:
            self._file.flush()
        data = np.loadtxt(self.dir / "samples.csv", delimiter=",", skiprows=1, ndmin=2)
        return data.reshape(-1, len(self.columns))

    def close(self, summary: dict[str, Any]) -> None:
        """Flush everything, write .mat, summary.json and the plot; safe to call twice."""
        if self.closed:
            return
        with self._trace_lock:
            self.closed = True
            if self.trace is not None:
                self.trace.stop()
        summary["trace_frames_dropped"] = self.frames_dropped
        self._file.flush()
        self._file.close()
        data = self.array()
        try:
            import scipy.io

            scipy.io.savemat(
                self.dir / "samples.mat",
                {c.replace(".", "_"): data[:, i] for i, c in enumerate(self.columns)},
            )
        except Exception as exc:
            summary.setdefault("warnings", []).append(f"samples.mat not written: {exc}")
        clean = {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in summary.items()
        }
        (self.dir / "summary.json").write_text(json.dumps(clean, indent=2) + "\n")
        self._plot(data)

    def _plot(self, data: np.ndarray) -> None:
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            return
        if not len(data):
            return
        fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        t = data[:, 0]
        for name in ("reference", "measurement"):
            axes[0].plot(t, data[:, self.columns.index(name)], label=name)
        axes[1].plot(t, data[:, self.columns.index("command")], label="command")
        for ax in axes:
            ax.grid(True)
            ax.legend()
        axes[-1].set_xlabel("time [s]")
        fig.tight_layout()
        fig.savefig(self.dir / "plot.png")
        plt.close(fig)
