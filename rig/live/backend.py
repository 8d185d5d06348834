"""What the live view's backends are: the ``Backend`` protocol the viewer thread
(``rig.live.view``) draws through, and ``LiveUnavailable``, which a backend (``rig.live.window``,
``rig.live.terminal``) raises when it cannot show the view. Apart from both, so that neither
imports the other."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from rig.live.channels import Channel

__all__ = ["Backend", "LiveUnavailable"]


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
