"""Starting ``rig`` itself as another process (the emulator for tests and benchmarks, a run to kill)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys

__all__ = ["spawn_emulator", "spawn_emulator_line", "spawn_rig", "stop_rig"]


def spawn_rig(*args: str, quiet: bool = False, stderr: bool = False) -> tuple[subprocess.Popen[str], str]:
    """Start ``python -m rig.cli ARGS`` unbuffered; returns the process and its first stdout line
    ("" when ``quiet``: stdout is discarded and nothing is waited for). stderr is kept for
    ``stop_rig`` only with ``stderr=True`` (an unread pipe would block a chatty process).

    Parameters
    ----------
    *args : str
        ``rig``'s arguments.
    quiet : bool, optional
        stdout discarded, nothing waited for.
    stderr : bool, optional
        Keep stderr for ``stop_rig``.

    Returns
    -------
    tuple[subprocess.Popen[str], str]
        (the process, its first stdout line).
    """
    proc = subprocess.Popen(
        [sys.executable, "-m", "rig.cli", *args],
        stdout=subprocess.DEVNULL if quiet else subprocess.PIPE,
        stderr=subprocess.PIPE if stderr else subprocess.DEVNULL,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        line = "" if quiet or proc.stdout is None else proc.stdout.readline()
    except BaseException:  # a stop signal while it starts: it is not left running, unowned
        stop_rig(proc, timeout=10)
        raise
    return proc, line


def stop_rig(proc: subprocess.Popen[str], *, timeout: float = 60.0) -> tuple[str, str]:
    """Ctrl-C (SIGINT) and wait; returns the rest of (stdout, stderr).

    Parameters
    ----------
    proc : subprocess.Popen[str]
        The process.
    timeout : float, optional
        [s] to wait.

    Returns
    -------
    tuple[str, str]
        The rest of (stdout, stderr).
    """
    proc.send_signal(signal.SIGINT)
    try:
        out, err = proc.communicate(timeout=timeout)
    except BaseException:  # it did not end in time, or a stop signal came to us meanwhile
        proc.kill()
        proc.communicate()
        raise
    return out or "", err or ""


def spawn_emulator(*args: str) -> tuple[subprocess.Popen[str], int]:
    """``rig emulate ARGS`` on a free socketcand port of 127.0.0.1: the process and the port.

    Parameters
    ----------
    *args : str
        ``rig emulate``'s arguments.

    Returns
    -------
    tuple[subprocess.Popen[str], int]
        (the process, its port).
    """
    proc, port, _ = spawn_emulator_line(*args)
    return proc, port


def spawn_emulator_line(*args: str) -> tuple[subprocess.Popen[str], int, str]:
    """``spawn_emulator``, and the line the emulator printed when it began to serve (what it
    serves, where, and the real-time scheduling it was granted).

    Parameters
    ----------
    *args : str
        ``rig emulate``'s arguments.

    Returns
    -------
    tuple[subprocess.Popen[str], int, str]
        (the process, its port, its first line).

    Raises
    ------
    RuntimeError
        If it did not start (its line and stderr said).
    """
    proc, line = spawn_rig("emulate", *args, "--port", "0", stderr=True)
    match = re.search(r"socketcand://127\.0\.0\.1:(\d+)", line)
    if match is None:
        proc.kill()
        _out, err = proc.communicate()
        raise RuntimeError(f"rig emulate {' '.join(args)} did not start: {line.strip()} {err[-2000:]}")
    return proc, int(match.group(1)), line
