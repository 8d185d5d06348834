"""The cross-process scenarios of ``rig faults``: emulator and host in processes of their own.

The world: ``rig emulate --device epos4`` (the maxon EPOS4 twin, real time on its own clock,
socketcand on 127.0.0.1) and ``rig run`` (real time, CSV at 50 rad/s, a 2 ms period, the
defaults otherwise: the run's set-up makes the drive watch the host's 0.1 s heartbeat, 0x1016 =
three of them, and quick-stop when it stops, 0x6007). This suite's own socketcand client, the
watcher, counts the drive's TPDOs; once 200 have come (the drive turns) the fault is injected.
Then each row adds to the lock-step rows' keys:

- ``motor_speed_after_1s``: the drive's velocity actual value (0x606C, in rad/s through the
  drive's own units, 0x60A9) read by SDO 1 s after the injection, or as soon as the host has
  exited if that is later (a CANopen server has one SDO client: the host's, while it lives);
  null where the emulator itself was killed (the drive is gone with it).
- ``stop_confirmed``: the host's summary's (its stop saw the drive at rest and disabled); false
  where the host died before it could say.

``read-only`` makes the run directory read-only (``chmod 555``) at the injection, ``rig run``
having no root's right to write past the permission bits (``without_write_override``): the run
goes on and its end names each file it could not write.

``detected_after_cycles`` counts the host's cycles from the injection (by the wall clock of
``started.json``) to its stop; ``samples_lost`` the cycles run minus the rows on disk (for a
killed host, the time not on disk after the last row, in cycles).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rig.emulator.spawn import spawn_emulator
from rig.faults.run_files import (
    NO_WRITE_OVERRIDE,
    SMALL_FILES,
    last_row_time,
    rows_on_disk,
    without_write_override,
)
from rig.faults.wire_probe import LinkRelay, Watcher, wait_for

__all__ = ["AFTER", "DEVICE", "PERIOD", "WIRE_SCENARIOS", "rows_on_disk", "without_write_override"]

DEVICE = "epos4"  #: the twin the scenarios run
PERIOD = 0.002  #: [s] the host's cycle
SPEED = 50.0  #: [rad/s] the speed the drive turns at when the fault comes
AFTER = 1.0  #: [s] from the injection to the speed's reading

CONFIG = """
[run]
duration = {duration}
time = "realtime"
period = {period}
output = "{out}"
name = "wire"

[bus]
interface = "socketcand"
channel = "can0"
host = "127.0.0.1"
port = {port}

[[axis]]
name = "motor"
kind = "cia402"
node_id = 1
mode = "csv"
eds = "{eds}"
enable_timeout = 5.0
abort_connection = "quick-stop"

[axis.limits]
command = 200.0
speed = 250.0

[controller]
kind = "speed-reference"
reads = ["motor"]
commands = ["motor"]

[reference]
kind = "constant"
value = {speed}
"""


class _World:
    """The emulator, the watcher and ``rig run`` of one scenario (see the module docstring)."""

    def __init__(
        self,
        out: Path,
        *,
        duration: float = 60.0,
        relay: bool = False,
        small_disk: bool = False,
        read_only: bool = False,
    ) -> None:
        self.out = out
        self.emulator, port = spawn_emulator("--device", DEVICE)
        self.port = port  #: the emulator's socketcand port
        self.relay = LinkRelay(port) if relay else None
        self.disk: str | None = None  #: how the disk was made small
        self.host: subprocess.Popen[str] | None = None
        try:
            from plant_emulator.device_profile import load_profile, zoo

            eds = load_profile(zoo()[DEVICE]).eds
            self.watcher = Watcher(port, eds)
            runs = out / "runs"
            runs.mkdir()
            limit = self._small_disk(runs) if small_disk else None
            config = out / "run.toml"
            config.write_text(
                CONFIG.format(
                    duration=duration,
                    period=PERIOD,
                    out=runs,
                    port=self.relay.port if self.relay else port,
                    eds=eds,
                    speed=SPEED,
                )
            )
            self.err = (out / "host.err").open("w")
            python = [sys.executable] if limit is None else [sys.executable, "-c", SMALL_FILES, str(limit)]
            if read_only:
                python = [sys.executable, "-c", NO_WRITE_OVERRIDE, sys.executable]
            self.host = subprocess.Popen(
                [*python, "-m", "rig.cli", "run", "--config", str(config), "--json"],
                stdout=subprocess.PIPE,
                stderr=self.err,
                text=True,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
            host = self.host
            wait_for(lambda: self.watcher.tpdos > 200 or host.poll() is not None, 60.0, "the drive's TPDOs")
            if host.poll() is not None:
                raise RuntimeError(f"rig run ended before the fault: {self.host_error()}")
        except BaseException:
            self.close()
            raise
        self.injected = time.time()

    def _small_disk(self, runs: Path) -> int | None:
        """A 512 KiB tmpfs on ``runs`` where mounting is allowed (a real ENOSPC); else None and a
        file-size limit of as much on ``rig run`` (EFBIG, the same error path)."""
        mount = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(runs)], capture_output=True, check=False
        )
        if mount.returncode == 0:
            self.disk = "a full 512 KiB tmpfs"
            return None
        self.disk = "a 512 KiB file-size limit (no tmpfs mount here)"
        return 512 * 1024

    def host_error(self) -> str:
        self.err.flush()
        return (self.out / "host.err").read_text()[-2000:]

    def finish(self, *, timeout: float = 60.0) -> dict[str, Any]:
        """Wait for ``rig run`` to exit; its summary: the one it printed, else (a run a signal
        stopped prints none) its run directory's summary.json; empty where there is neither."""
        assert self.host is not None
        try:
            out, _ = self.host.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.host.kill()
            out, _ = self.host.communicate()
        with contextlib.suppress(ValueError):
            if out.strip():
                summary: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
                return summary
            start = self.started()
            if start is not None and (start[1] / "summary.json").is_file():
                summary = json.loads((start[1] / "summary.json").read_text())
                return summary
        return {}

    def read_drive(self) -> tuple[float | None, bool | None]:
        """(speed [rad/s], no torque) of the drive ``AFTER`` s after the injection (see the module
        docstring); (None, None) where the emulator is gone."""
        left = self.injected + AFTER - time.time()
        if left > 0.0:
            time.sleep(left)  # the reading's time, not a decision
        if self.emulator.poll() is not None:
            return None, None
        speed, state = self.watcher.speed(), self.watcher.state()
        return speed, (None if state is None else state.torque_off)

    def started(self) -> tuple[float, Path] | None:
        """(wall time [s] of the run's start, run directory) from started.json."""
        for mark in (self.out / "runs").glob("*/started.json"):
            with contextlib.suppress(ValueError, KeyError, OSError):
                return float(json.loads(mark.read_text())["wall_time"]), mark.parent
        return None

    def row(self, summary: dict[str, Any], **extra: Any) -> dict[str, Any]:
        """The scenario's row from the host's summary and the drive's reading."""
        speed, disabled = self.read_drive()
        start = self.started()
        detected = None
        if summary.get("safe_stop_reason") and start is not None:
            detected = max(0, summary["cycles"] - round((self.injected - start[0]) / PERIOD))
        rows = rows_on_disk(start[1]) if start else 0
        return {
            "detected_after_cycles": detected,
            "drive_disabled": disabled,
            "samples_lost": summary["cycles"] - rows if "cycles" in summary else None,
            "message": summary.get("safe_stop_reason") or "completed without a stop",
            "motor_speed_after_1s": None if speed is None else round(speed, 3),
            "stop_confirmed": bool(summary.get("stop_confirmed")),
            **extra,
        }

    def close(self) -> None:
        if self.host is not None and self.host.poll() is None:
            self.host.kill()
            self.host.communicate()
        if hasattr(self, "watcher"):
            self.watcher.close()
        if self.relay is not None:
            self.relay.drop()
        if self.emulator.poll() is None:
            self.emulator.send_signal(signal.SIGINT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.emulator.communicate(timeout=10)
        if self.emulator.poll() is None:
            self.emulator.kill()
        if hasattr(self, "err"):
            self.err.close()
        if self.disk and self.disk.startswith("a full"):
            subprocess.run(["umount", "-l", str(self.out / "runs")], capture_output=True, check=False)


def _scenario(run: Callable[[_World], dict[str, Any]], **world: Any) -> Callable[[str], dict[str, Any]]:
    def scenario(out: str) -> dict[str, Any]:
        w = _World(Path(out), **world)
        try:
            return run(w)
        finally:
            w.close()

    return scenario


def _emulator_sigkill(w: _World) -> dict[str, Any]:
    w.emulator.kill()
    return w.row(w.finish())


def _emulator_sigstop(w: _World) -> dict[str, Any]:
    w.emulator.send_signal(signal.SIGSTOP)
    time.sleep(0.5)  # the fault: the emulator frozen for 0.5 s
    w.emulator.send_signal(signal.SIGCONT)
    return w.row(w.finish())


def _link_drop(w: _World) -> dict[str, Any]:
    assert w.relay is not None
    w.relay.drop()
    return w.row(w.finish())


def _host_sigterm(w: _World) -> dict[str, Any]:
    assert w.host is not None
    w.host.send_signal(signal.SIGTERM)
    return w.row(w.finish())


def _host_sigkill(w: _World) -> dict[str, Any]:
    assert w.host is not None
    w.host.kill()
    w.finish()
    start = w.started()
    lost = None
    if start is not None:  # the time not on disk: from the last row's t to the kill
        lost = max(0, round((w.injected - start[0] - last_row_time(start[1])) / PERIOD))
    row = w.row({}, samples_lost=lost)  # 1 s after the kill: the drive has had its say
    codes = ", ".join(f"0x{c:04X}" for c in w.watcher.emcy) or "none"
    row["message"] = f"host killed; the drive's EMCY: {codes}; {lost} samples not on disk"
    return row


def _client_never_reads(w: _World) -> dict[str, Any]:
    """A second socketcand client opens the bus in raw mode and never reads; the run ends by
    its duration."""
    assert w.host is not None
    with socket.create_connection(("127.0.0.1", w.port)) as silent:
        silent.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        silent.sendall(b"< open can0 >< rawmode >")
        summary = w.finish()
    return w.row(summary)


def _not_written(summary: dict[str, Any]) -> str:
    files = summary.get("files_not_written")
    return f"; not written whole: {', '.join(files)}" if files else ""


def _disk_full(w: _World) -> dict[str, Any]:
    """The run's directory on a small disk: the stop comes when it is full (no injection time)."""
    summary = w.finish()
    message = f"{summary.get('safe_stop_reason')} ({w.disk}){_not_written(summary)}"
    return w.row(summary, detected_after_cycles=None, message=message)


def _read_only(w: _World) -> dict[str, Any]:
    """The run directory turns read-only mid-run: the run goes on; its end names what it could
    not write, and its exit code says so."""
    assert w.host is not None
    start = w.started()
    assert start is not None  # the drive turns: the cycles have started
    start[1].chmod(0o555)
    try:
        summary = w.finish()
    finally:
        start[1].chmod(0o755)
    reason = summary.get("safe_stop_reason") or "completed without a stop"
    message = f"{reason}{_not_written(summary)} (exit code {w.host.returncode})"
    return w.row(summary, detected_after_cycles=None, message=message)


#: name -> scenario(out directory) -> row
WIRE_SCENARIOS: dict[str, Callable[[str], dict[str, Any]]] = {
    "emulator-sigkill": _scenario(_emulator_sigkill),
    "emulator-sigstop": _scenario(_emulator_sigstop),
    "link-drop": _scenario(_link_drop, relay=True),
    "host-sigterm": _scenario(_host_sigterm),
    "host-sigkill": _scenario(_host_sigkill),
    "client-never-reads": _scenario(_client_never_reads, duration=3.0),
    "disk-full": _scenario(_disk_full, small_disk=True),
    "read-only": _scenario(_read_only, duration=3.0, read_only=True),
}
