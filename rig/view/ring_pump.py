"""The view's process's reader of a run's shared ring (``rig run --view``): a thread there that
reads the ring ``RATE`` times a second, decimates the new rows for the screen and pushes them,
with the axes' states of the latest row, into the live scope. All of the view's per-update work
is here, in a process of its own (``rig.view.process``): the run's process only writes the ring
(``rig.view.beside``).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence

from rig.live.ring_states import state_words
from rig.live.shared_ring import RingReader
from rig.view.scope import Scope, decimate

__all__ = ["RingPump"]

log = logging.getLogger(__name__)


class RingPump:
    """``reader``'s rows into ``scope`` from a thread, every ``1 / rate`` s, until ``stop``.

    Parameters
    ----------
    scope : Scope
        The live scope.
    reader : RingReader
        The run's ring.
    names : Sequence[str]
        The axes whose state columns follow each row.
    rate : float
        [Hz] of updates.
    """

    def __init__(self, scope: Scope, reader: RingReader, names: Sequence[str], rate: float) -> None:
        self.scope, self.reader, self.names = scope, reader, list(names)
        self.every = 1.0 / rate
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="rig-view-ring", daemon=True)

    def start(self) -> None:
        """Read from a thread of its own."""
        self._thread.start()

    def pump(self) -> int:
        """One update: the rows since the last, decimated, and the latest row's states.

        Returns
        -------
        int
            Rows read.
        """
        rows, _ = self.reader.read()
        width = self.reader.layout.width
        states = (
            state_words(rows[-1, 1 + width :].tolist(), self.names, self.reader.texts)
            if len(rows) and self.names
            else None
        )
        new = rows[:, 1 : 1 + width]
        self.scope.push(decimate(new) if len(new) else new, states)
        return len(rows)

    def _run(self) -> None:
        try:
            while not self._stop.wait(self.every):
                self.pump()
        except Exception as exc:  # the view goes on with what it has; the run never knows
            log.warning("the live scope stopped reading the run: %s", exc)

    def stop(self) -> None:
        """Stop the thread (if started), take the last rows and stop the scope."""
        self._stop.set()
        if self._thread.ident is not None:
            self._thread.join(2.0)
        try:
            self.pump()
        finally:
            self.scope.stop()
