"""The live view in a matplotlib window, drawn by a process of its own (a GUI wants its main
thread, and the host's is the control loop's).

Per axis a row of two plots over the last ``SPAN`` seconds: its reference and measurement, and
its command, each labelled with its unit. The host's side (``WindowBackend``, in the viewer
thread of ``rig.live.view``) sends the rows that are new since its last draw, thinned to at
most ``MOST`` points, over a pipe; the window's process (``serve``) keeps the last ``SPAN``
seconds and redraws. The window closes at the end of the run (``plot.png`` in the run
directory has the whole run); a window the user closes ends the live view, not the run.
Ctrl-C in the terminal reaches the run only (the window's process ignores SIGINT).
"""

from __future__ import annotations

import bisect
import math
import multiprocessing
import signal
from collections.abc import Sequence
from typing import Any

import numpy as np

from rig.live.backend import LiveUnavailable
from rig.live.channels import Channel

__all__ = ["MOST", "SPAN", "WindowBackend", "build_figure", "serve", "update_figure", "window_points"]

SPAN = 10.0  #: [s] of the run the window shows
MOST = 200  #: points sent per draw at most
_NOT_WINDOWS = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}  #: matplotlib's file backends
_NAMES = ("reference", "measurement", "command")


def window_points(
    channels: Sequence[Channel], rows: Sequence[Sequence[float]], after: float, most: int = MOST
) -> np.ndarray:
    """The ``rows`` (oldest first) later than ``after`` [s], every k-th so at most ``most``, as an
    array: per point its time [s], then per channel its reference, measurement and command (NaN
    where the axis has none).

    Parameters
    ----------
    channels : Sequence[Channel]
        The axes shown.
    rows : Sequence[Sequence[float]]
        The rows, oldest first.
    after : float
        [s] the last time already drawn.
    most : int, optional
        Points at most.

    Returns
    -------
    np.ndarray
        Time, then reference, measurement and command per channel.
    """
    start = bisect.bisect_right(rows, after, key=lambda r: r[0])
    new = rows[start:]
    step = max(1, math.ceil(len(new) / most))
    picked = list(new[len(new) - 1 :: -step])[::-1]  # the last row always among them
    cols = [i for c in channels for i in c.columns]
    return np.array(
        [[r[0], *(math.nan if i is None else r[i] for i in cols)] for r in picked], dtype=float
    ).reshape(len(picked), 1 + len(cols))


def build_figure(fig: Any, channels: Sequence[Channel], title: str) -> list[dict[str, Any]]:
    """Per channel a row of two plots on ``fig`` (a matplotlib Figure): reference and
    measurement, and command, with units, legends and ``title``; returns per channel its lines
    by name ("reference", "measurement", "command").

    Parameters
    ----------
    fig : Any
        A matplotlib Figure.
    channels : Sequence[Channel]
        The axes shown.
    title : str
        The run's name.

    Returns
    -------
    list[dict[str, Any]]
        Per channel, its lines by name.
    """
    axes = fig.subplots(max(1, len(channels)), 2, sharex=True, squeeze=False)
    lines: list[dict[str, Any]] = []
    for (left, right), c in zip(axes, channels):
        found: dict[str, Any] = {}
        what = "measurement" if c.measured == "law" else f"measured {c.measured}"
        for name, index, ax, label in (
            ("reference", c.reference, left, "reference"),
            ("measurement", c.measurement, left, what),
            ("command", c.command, right, "command"),
        ):
            if index is not None:
                (found[name],) = ax.plot([], [], label=label, color=f"C{_NAMES.index(name)}")
        unit = c.units[1] or c.units[0]
        left.set_title(f"{c.axis}: reference, measurement" if c.reference is not None else c.axis)
        left.set_ylabel(f"{c.axis} [{unit}]" if unit else c.axis)
        right.set_title(f"{c.axis}: command" if c.command is not None else f"{c.axis}: no command")
        right.set_ylabel(f"command [{c.units[2]}]" if c.units[2] else "command")
        for ax in (left, right):
            ax.grid(True)
            if ax.lines:
                ax.legend(loc="upper left")
        lines.append(found)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    fig.suptitle(f"live: {title}")
    return lines


def update_figure(lines: Sequence[dict[str, Any]], history: np.ndarray) -> None:
    """Set the lines of ``build_figure`` to ``history`` (``window_points``' columns), rescaled.

    Parameters
    ----------
    lines : Sequence[dict[str, Any]]
        ``build_figure``'s result.
    history : np.ndarray
        ``window_points``' columns.
    """
    t = history[:, 0]
    for k, found in enumerate(lines):
        for j, name in enumerate(_NAMES):
            if name in found:
                found[name].set_data(t, history[:, 1 + 3 * k + j])
        for ax in {line.axes for line in found.values()}:
            ax.relim()
            ax.autoscale_view()


def _keep(history: np.ndarray | None, points: np.ndarray) -> np.ndarray:
    """``points`` after ``history``, the last ``SPAN`` seconds of them."""
    both = points if history is None else np.concatenate([history, points])
    return both[both[:, 0] >= both[-1, 0] - SPAN] if len(both) else both


def serve(conn: Any) -> None:
    """The window's process: "ready" (or "unavailable" and why) on ``conn``, then ("open",
    channels, title), ("rows", points) and ("end",) from the host until the end or the window
    is closed.

    Parameters
    ----------
    conn : Any
        The pipe to the host.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the run's to handle
    try:
        import matplotlib

        backend = matplotlib.get_backend()
        if backend.lower() in _NOT_WINDOWS:
            conn.send(("unavailable", f"matplotlib has no window backend here (it chose {backend})"))
            return
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=(10, 6))
        plt.show(block=False)
    except Exception as exc:
        conn.send(("unavailable", f"matplotlib cannot open a window: {type(exc).__name__}: {exc}"))
        return
    conn.send(("ready", backend))
    _show(conn, plt, fig)


def _show(conn: Any, plt: Any, fig: Any) -> None:
    lines: list[dict[str, Any]] | None = None
    history: np.ndarray | None = None
    ended = False
    while not ended and plt.fignum_exists(fig.number):
        dirty = False
        try:
            while not ended and conn.poll():
                msg = conn.recv()
                if msg[0] == "open":
                    lines = build_figure(fig, msg[1], msg[2])
                elif msg[0] == "rows" and len(msg[1]):
                    history, dirty = _keep(history, msg[1]), True
                ended = msg[0] == "end"
        except (EOFError, OSError):  # the host is gone
            ended = True
        if dirty and lines is not None and history is not None:
            update_figure(lines, history)
            fig.canvas.draw_idle()
        if not ended:
            plt.pause(0.1)
    plt.close(fig)


class WindowBackend:
    """The host's side: starts the window's process (LiveUnavailable when it cannot open a
    window, within ``timeout`` [s]) and sends it the new rows at each draw.

    Parameters
    ----------
    timeout : float, optional
        [s] for the window's process to say it is ready.

    Raises
    ------
    LiveUnavailable
        If the window cannot open.
    """

    def __init__(self, *, timeout: float = 60.0) -> None:
        ctx = multiprocessing.get_context("spawn")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=serve, args=(child,), name="rig-live-window", daemon=True)
        self._proc.start()
        child.close()
        self.channels: list[Channel] = []
        self._after = -math.inf  #: [s] the last row sent
        try:
            if not self._conn.poll(timeout):
                raise LiveUnavailable(f"the live window did not open within {timeout:g} s")
            kind, text = self._conn.recv()
        except (EOFError, OSError):
            self.close()
            raise LiveUnavailable("the live window's process ended before it opened") from None
        except LiveUnavailable:
            self.close()
            raise
        if kind != "ready":
            self.close()
            raise LiveUnavailable(text)

    def _send(self, msg: tuple[Any, ...]) -> None:
        try:
            self._conn.send(msg)
        except (OSError, EOFError):  # BrokenPipeError: the window was closed
            raise LiveUnavailable("the live window was closed") from None

    def open(self, channels: Sequence[Channel], title: str) -> None:
        """Open the window on ``channels`` under ``title``.

        Parameters
        ----------
        channels : Sequence[Channel]
            The axes shown.
        title : str
            The run's name.
        """
        self.channels = list(channels)
        self._send(("open", self.channels, title))

    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        """Send the window the rows since the last draw.

        Parameters
        ----------
        rows : Sequence[Sequence[float]]
            The latest rows, oldest first.
        final : bool, optional
            The run has ended.
        """
        points = window_points(self.channels, rows, self._after)
        if len(points):
            self._after = float(points[-1, 0])
            self._send(("rows", points))

    def close(self) -> None:
        """Close the window (it has shown the last rows) and end its process."""
        try:
            self._conn.send(("end",))
        except (OSError, EOFError, ValueError):
            pass
        self._proc.join(2.0)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(1.0)
        self._conn.close()
