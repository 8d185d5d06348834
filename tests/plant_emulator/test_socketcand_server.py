"""The socketcand rawmode server of ``rig emulate``: a server never started stops at once."""

from __future__ import annotations

import threading

from plant_emulator.lockstep import SyncHub
from plant_emulator.socketcand_server import SocketcandServer


def test_a_server_never_started_stops_without_waiting() -> None:
    """``rig emulate`` stops the server when building the devices fails (a bad --param)."""
    server = SocketcandServer(SyncHub(), threading.RLock(), port=0)
    done = threading.Event()
    thread = threading.Thread(target=lambda: (server.stop(), done.set()), daemon=True)
    thread.start()
    assert done.wait(5.0)  # socketserver's shutdown() would wait forever here
