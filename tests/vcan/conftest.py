"""The vcan tier: ``rig emulate`` as its own process on vcan0, the host on python-can's socketcan."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from collections.abc import Callable, Iterator

import pytest


def vcan_unavailable() -> str | None:
    """Why vcan0 cannot be used here, or None."""
    if not hasattr(socket, "AF_CAN"):
        return "this Python has no AF_CAN"
    try:
        with socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW) as s:
            s.bind(("vcan0",))
    except OSError as exc:
        return f"no SocketCAN vcan0 here ({exc.strerror}); see the README, Testing with virtual CAN"
    return None


@pytest.fixture(autouse=True)
def _need_vcan() -> None:
    reason = vcan_unavailable()
    if reason:
        pytest.skip(reason)


@pytest.fixture
def start_emulator() -> Iterator[Callable[..., subprocess.Popen[str]]]:
    """Start ``rig emulate`` on vcan0 with the given arguments; stopped (SIGINT) after the test."""
    procs: list[subprocess.Popen[str]] = []

    def start(*args: str) -> subprocess.Popen[str]:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "rig.cli",
                "emulate",
                "--interface",
                "socketcan",
                "--channel",
                "vcan0",
                *args,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        procs.append(proc)
        assert proc.stdout is not None
        line = proc.stdout.readline()  # "rig emulate: ... on socketcan:vcan0; Ctrl-C stops"
        assert "socketcan:vcan0" in line, line + (proc.stderr.read() if proc.stderr else "")
        return proc

    yield start
    for proc in procs:
        proc.send_signal(signal.SIGINT)
        _out, err = proc.communicate(timeout=60)
        assert proc.returncode == 0, err
