"""rig started as another process stops on SIGINT, also from a parent that ignores it."""

from __future__ import annotations

import signal
import subprocess
import sys

from rig.emulator.spawn import stop_rig


def test_a_rig_whose_parent_ignores_sigint_still_stops_on_it() -> None:
    """A script's background job (``rig bench stops > log &``) inherits SIGINT ignored; the
    emulator it starts must still end on ``stop_rig``'s SIGINT (it used to outlive it)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "rig.cli", "emulate", "--preset", "dc-servo", "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),  # noqa: PLW1509
    )
    try:
        assert proc.stdout is not None and "socketcand://" in proc.stdout.readline()
        stop_rig(proc, timeout=30)
        assert proc.returncode == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
