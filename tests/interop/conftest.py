"""The interop tier: drive-rig against software nobody here wrote (can-utils, libmodbus's mbpoll,
socat, an independent CANopen stack from PyPI).

Selected with ``-m interop`` only (the root conftest deselects it otherwise). A tool that is
missing skips its tests with the reason; with ``RIG_INTEROP_REQUIRE=1`` (``.ci/run`` sets it)
a missing tool or a missing vcan0 fails instead, so CI skips nothing.

``CanDump`` is ``candump -L`` in its own process, its lines parsed as they come; every wait in
this tier is for a condition (a frame seen, a state reached) with a generous deadline, never a
sleep that decides.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import pytest

from tests.vcan.conftest import start_emulator, vcan_unavailable

__all__ = ["start_emulator"]  # rig emulate on vcan0, stopped after the test (the vcan tier's fixture)

REQUIRED = os.environ.get("RIG_INTEROP_REQUIRE") == "1"
#: [s] how long any condition of this tier is waited for (the VM's CPU is 10-25x slower)
DEADLINE = 60.0


def unavailable(reason: str) -> None:
    """Skip (a developer's machine) or fail (CI: ``RIG_INTEROP_REQUIRE=1``) with ``reason``."""
    if REQUIRED:
        pytest.fail(f"interop tier required here, but {reason}")
    pytest.skip(reason)


def need_tools(*names: str) -> None:
    missing = [n for n in names if shutil.which(n) is None]
    if missing:
        unavailable(f"not installed: {', '.join(missing)} (Debian: apt-get install can-utils mbpoll socat)")


def need_vcan() -> None:
    reason = vcan_unavailable()
    if reason:
        unavailable(reason)


def wait_for(predicate: Callable[[], object], what: str, timeout: float = DEADLINE) -> None:
    """Poll ``predicate`` every 5 ms until it is true; fail naming ``what`` after ``timeout`` [s]."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.005)


@dataclass(frozen=True)
class Frame:
    """One classic CAN frame as ``candump -L`` logs it: ``(stamp) vcan0 1A0#0102``."""

    stamp: float
    can_id: int
    data: bytes
    remote: bool = False

    def __str__(self) -> str:
        return f"{self.can_id:03X}#{'R' if self.remote else self.data.hex().upper()}"


LOG_LINE = re.compile(r"^\((\d+\.\d+)\) (\S+) ([0-9A-F]{3,8})#(R\d?|[0-9A-F]*)$")


def parse_log_line(line: str) -> Frame:
    m = LOG_LINE.match(line.strip())
    assert m is not None, f"not a candump -L line: {line!r}"
    stamp, _iface, can_id, data = m.groups()
    if data.startswith("R"):
        return Frame(float(stamp), int(can_id, 16), b"", remote=True)
    return Frame(float(stamp), int(can_id, 16), bytes.fromhex(data))


class CanDump:
    """``candump -L vcan0`` in its own process; ``frames`` grows as it logs."""

    MARK_ID = 0x7FF  #: not a CANopen COB-ID any device here uses (0x700 + 127 is the last heartbeat)

    def __init__(self, channel: str = "vcan0") -> None:
        self.channel = channel
        self.frames: list[Frame] = []
        self._lock = threading.Lock()
        self._marks = 0
        self.proc = subprocess.Popen(
            ["stdbuf", "-oL", "candump", "-L", channel],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self._reader = threading.Thread(target=self._read, name="candump", daemon=True)
        self._reader.start()
        self.mark()  # candump is listening once it logs a frame sent after it started

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            frame = parse_log_line(line)
            with self._lock:
                self.frames.append(frame)

    def snapshot(self) -> list[Frame]:
        with self._lock:
            return list(self.frames)

    def mark(self) -> int:
        """Send a marker frame (cansend) until candump has logged it; its index in ``frames``."""
        self._marks += 1
        payload = self._marks.to_bytes(4, "big")
        marker = Frame(0.0, self.MARK_ID, payload)
        deadline = time.monotonic() + DEADLINE
        while True:
            cansend(self.channel, f"{self.MARK_ID:03X}#{payload.hex()}")
            end = time.monotonic() + 1.0
            while time.monotonic() < end:
                for i, f in enumerate(self.snapshot()):
                    if f.can_id == marker.can_id and f.data == marker.data:
                        return i
                if self.proc.poll() is not None:
                    pytest.fail(f"candump exited {self.proc.returncode}: {self.proc.stderr.read()}")  # type: ignore[union-attr]
                time.sleep(0.005)
            if time.monotonic() > deadline:
                pytest.fail("candump never logged the marker frame")

    def wait(self, predicate: Callable[[Frame], bool], start: int, what: str) -> tuple[int, Frame]:
        """The first frame at index >= ``start`` that satisfies ``predicate``, and its index."""
        found: list[tuple[int, Frame]] = []

        def seen() -> bool:
            frames = self.snapshot()
            for i in range(start, len(frames)):
                if predicate(frames[i]):
                    found.append((i, frames[i]))
                    return True
            return False

        wait_for(seen, what)
        return found[0]

    def close(self) -> None:
        self.proc.terminate()
        self.proc.wait(timeout=10)
        self._reader.join(timeout=10)
        for pipe in (self.proc.stdout, self.proc.stderr):
            if pipe is not None:
                pipe.close()


def cansend(channel: str, frame: str) -> None:
    done = subprocess.run(
        ["cansend", channel, frame], capture_output=True, text=True, timeout=30, check=False
    )
    assert done.returncode == 0, f"cansend {channel} {frame}: exit {done.returncode}: {done.stderr}"


@pytest.fixture
def can_tools() -> None:
    need_tools("candump", "cansend", "cangen", "stdbuf")
    need_vcan()


@pytest.fixture
def candump(can_tools: None) -> Iterator[CanDump]:
    dump = CanDump()
    yield dump
    dump.close()


@pytest.fixture(autouse=True)
def _slow_machine(monkeypatch: pytest.MonkeyPatch) -> None:
    from drivers.canopen_axis import CanopenAxis

    monkeypatch.setattr(CanopenAxis, "SDO_TIMEOUT", 2.0)  # the VM's emulated CPU is slow, not the device
