"""A serial line made of two pseudo-terminals: what one end writes, the other reads.

Stands in for an RS-485 line between a Modbus RTU master and the emulated
inverter on machines without serial hardware. A relay thread copies bytes
between the two pty masters; ``close()`` stops it.
"""

from __future__ import annotations

import os
import select
import threading
import tty

__all__ = ["PtyLink"]


class PtyLink:
    """Two linked serial device paths, ``port_a`` and ``port_b``."""

    def __init__(self) -> None:
        self._masters: list[int] = []
        self._slaves: list[int] = []
        names = []
        for _ in range(2):
            master, slave = os.openpty()
            tty.setraw(slave)
            self._masters.append(master)
            self._slaves.append(slave)
            names.append(os.ttyname(slave))
        self.port_a, self.port_b = names
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._relay, name="pty-link", daemon=True)
        self._thread.start()

    def _relay(self) -> None:
        a, b = self._masters
        peer = {a: b, b: a}
        while not self._stop.is_set():
            ready, _, _ = select.select([a, b], [], [], 0.05)
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                if data:
                    os.write(peer[fd], data)

    def close(self) -> None:
        """Stop the relay and close both pseudo-terminal pairs."""
        self._stop.set()
        self._thread.join(timeout=1.0)
        for fd in self._masters + self._slaves:
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self) -> PtyLink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
