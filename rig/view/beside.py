"""``rig run --view``'s part in the run's process: the shared ring the recorder writes, and nothing
that works per update.

``SharedView`` takes a live view's place in a run (``rig.host.session``: ``start``, ``rows``,
``thread``, ``stop``), but has no thread: at the start it makes a ``rig.live.shared_ring.SharedRing``
as wide as the recorder's row plus the axes' state columns (``rig.live.ring_states``), sends the
run's description and the ring (its file descriptor) to the view's process, and becomes the
recorder's ``live``: each cycle's row is written there by the loop (an O(1) numpy row write and a
counter, no lock). The view's process reads it ``RATE`` times a second (``rig.view.ring_pump``).
At the end it says "stop" and lets go of the ring. Per run: three messages over the pipe
("open", "ring", "stop"), none per update. A view process that has died costs the run nothing:
the ring is the run's memory, and a message it cannot take is logged once (``PipeSink``).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rig.live.channels import Channel
from rig.live.shared_ring import SharedRing
from rig.view.feed import live_meta

__all__ = ["KEEP", "SharedView"]

log = logging.getLogger(__name__)

KEEP = 4096  #: rows in the ring (4 s at 1 kHz; the reader takes them 30 times a second)


class SharedView:
    """The live view of ``rig run --view``: the ring, fed by the recorder, read by the view's
    process over ``sink`` (``rig.view.process.PipeSink``); the run directory is ``output``/title.

    Parameters
    ----------
    sink : Any
        The view's process's pipe (``rig.view.process.PipeSink``: ``open``, ``ring``, ``stop``).
    output : str | Path
        The runs' folder.
    keep : int, optional
        Rows in the ring.
    """

    thread = None  #: no thread of its own in the run's process

    def __init__(self, sink: Any, output: str | Path, keep: int = KEEP) -> None:
        self.sink = sink
        self.output = Path(output)
        self.keep = keep
        self.axes: list[Any] = []  #: the run's axes (``watch``), whose states the ring carries
        self.rows: SharedRing | None = None

    def watch(self, axes: Sequence[Any]) -> None:
        """The run's axes, set up and enabled (their states go into the ring's rows).

        Parameters
        ----------
        axes : Sequence[Any]
            The axes (``drivers.base.AxisDriver``).
        """
        self.axes = list(axes)

    def start(self, channels: Sequence[Channel], title: str) -> None:
        """The run begins: its description and the ring to the view's process.

        Parameters
        ----------
        channels : Sequence[Channel]
            The axes shown (the page picks its own from the description).
        title : str
            The run's name.
        """
        try:
            meta = live_meta(self.output / title, title)
            rows = SharedRing(self.keep, len(meta["columns"]), self.axes)
        except Exception as exc:  # never into the run: the view shows no rows, the run goes on
            log.warning("the live view has no rows: %s (the run goes on)", exc)
            return
        self.sink.open(meta)
        assert rows.fd is not None
        self.sink.ring(rows.fd, rows.layout.args(), [str(a.name) for a in self.axes])
        rows.close_fd()  # the view's process has its own (or is gone)
        self.rows = rows

    def stop(self) -> None:
        """The run has ended: the view's process reads the last rows and stops its scope. Safe
        to call twice or unstarted."""
        rows, self.rows = self.rows, None
        if rows is not None:  # its descriptor closed at the start: the mapping goes with ``rows``
            self.sink.stop()
