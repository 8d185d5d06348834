"""A run's ``plot.png``: reference and measurement, and the command, titled with the run's name,
the axes labelled with their units (``rig.host.recorder.Recorder.plot`` draws it at the close).

matplotlib's ``Figure`` without pyplot: no global state (a sweep's worker may run points in
threads) and no pyplot to import.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rig.host.storage import write_atomic

__all__ = ["plot_run"]


def _label(docs: dict[str, dict[str, str]], column: str, name: str) -> str:
    """``name [unit]`` with the column's unit from ``docs`` (none for a replay's mixed units)."""
    unit = docs.get(column, {}).get("unit", "")
    return f"{name} [{unit}]" if unit else name


def plot_run(
    folder: Path,
    data: np.ndarray,
    columns: Sequence[str],
    docs: dict[str, dict[str, str]],
    *,
    durable: bool = True,
) -> Any:
    """Write ``folder``/plot.png from the samples ``data``.

    Parameters
    ----------
    folder : Path
        The run directory (its name titles the plot).
    data : np.ndarray
        Rows of ``columns``, the time first (at the close, the ``readback.Envelope`` of the run's).
    columns : Sequence[str]
        The samples' columns (``reference``, ``measurement`` and ``command`` are drawn).
    docs : dict[str, dict[str, str]]
        Each column's unit and meaning (the axes' labels).
    durable : bool
        fsync the file before its rename.

    Returns
    -------
    Any
        The matplotlib figure; None without matplotlib or samples.
    """
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
        axes[0].plot(t, data[:, columns.index(name)], label=name)
    axes[1].plot(t, data[:, columns.index("command")], label="command (first commanded axis)")
    axes[0].set_title("controlled variable")
    axes[0].set_ylabel(_label(docs, "measurement", "reference, measurement"))
    axes[1].set_title("command")
    axes[1].set_ylabel(_label(docs, "command", "command"))
    for ax in axes:
        ax.grid(True)
        ax.legend()
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"run {folder.name}")
    fig.tight_layout()
    write_atomic(folder / "plot.png", lambda f: fig.savefig(f, format="png"), binary=True, sync=durable)
    return fig
