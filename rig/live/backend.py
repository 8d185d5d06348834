"""What the live view's backends are: the ``Backend`` protocol the viewer thread
(``rig.live.view``) draws through, and ``LiveUnavailable``, which a backend (``rig.live.window``,
``rig.live.terminal``) raises when it cannot show the view. Apart from both, so that neither
imports the other. ``Live`` is what a run takes as its live view (``rig.live.view.LiveView``, or
``rig run --view``'s ``rig.view.beside.SharedView``), ``RowSink`` where its recorder puts each row."""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Protocol

from rig.live.channels import Channel

__all__ = ["Backend", "Live", "LiveUnavailable", "RowSink"]


class LiveUnavailable(Exception):
    """The live view asked for cannot be shown (no matplotlib, no display, the window closed)."""


class Backend(Protocol):
    """What draws the rows: ``open`` once, ``draw`` a few times a second, ``close`` once."""

    def open(self, channels: Sequence[Channel], title: str) -> None:
        """Show the view of ``channels`` under ``title``.

        Parameters
        ----------
        channels : Sequence[Channel]
            The axes shown.
        title : str
            The run's name.
        """

    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        """Show the latest ``rows`` (oldest first).

        Parameters
        ----------
        rows : Sequence[Sequence[float]]
            The rows, ``row[0]`` the time [s].
        final : bool, optional
            The run has ended.
        """

    def close(self) -> None:
        """Close the view."""


class RowSink(Protocol):
    """Where a recorder puts each row it has written (once a cycle, on the loop's thread)."""

    def append(self, row: Sequence[float]) -> None:
        """Take ``row`` (O(1), no lock, never waits).

        Parameters
        ----------
        row : Sequence[float]
            The row, ``row[0]`` the time [s].
        """


class Live(Protocol):
    """A run's live view: ``start`` before the cycles, ``rows`` fed by the recorder, ``stop`` after."""

    @property
    def rows(self) -> RowSink | None:
        """Where the recorder puts the rows (None: nowhere)."""

    @property
    def thread(self) -> threading.Thread | None:
        """Its thread in the run's process, if any (it shares the interpreter lock)."""

    def start(self, channels: Sequence[Channel], title: str) -> None:
        """Start showing ``channels`` of the rows to come under ``title``.

        Parameters
        ----------
        channels : Sequence[Channel]
            The axes shown.
        title : str
            The run's name.
        """

    def stop(self) -> None:
        """The run has ended (safe to call twice or unstarted)."""
