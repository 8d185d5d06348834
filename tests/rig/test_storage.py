"""A run directory that cannot be written is a safe stop, and the close keeps what it can.

Each case is in lock-step on the emulated drive (deterministic): the run directory removed
mid-run, the trace's disk full mid-run, and, in a process of its own with a file-size limit
(RLIMIT_FSIZE: writes past it fail as on a full disk), ``rig run`` itself.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import pathlib
import resource
import shutil
import signal
import subprocess
import sys

import pytest

from rig.config import load_config
from rig.host.session import Session
from rig.host.storage import write_atomic

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "dc_servo_position.toml"


def _session(tmp_path: pathlib.Path) -> Session:
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=1.0))
    return Session(cfg, emulate=True)


def test_a_removed_run_directory_stops_the_run_and_nothing_is_lost(tmp_path: pathlib.Path) -> None:
    with _session(tmp_path) as session:
        run_dir = session.recorder.dir

        def remove(k: int) -> None:
            if k >= session.cycles // 3 and run_dir.exists():
                shutil.rmtree(run_dir)

        session.start()
        summary = session.run(progress=remove)
    reason = summary["safe_stop_reason"]
    assert reason is not None and "the run directory was removed" in reason, reason
    assert summary["stop_confirmed"] is True
    assert any("made again" in w for w in summary["warnings"])
    rows = (run_dir / "samples.csv").read_text().splitlines()
    assert len(rows) == summary["cycles"] + 1  # the header and every cycle run
    assert json.loads((run_dir / "summary.json").read_text())["cycles"] == summary["cycles"]
    assert (run_dir / "samples.mat").stat().st_size > 0


def test_a_trace_that_cannot_be_written_stops_the_run_not_the_bus(tmp_path: pathlib.Path) -> None:
    class FullDisk:
        def write(self, text: str) -> int:
            raise OSError(errno.ENOSPC, "No space left on device")

        def close(self) -> None:
            pass

    with _session(tmp_path) as session:
        recorder = session.recorder

        def fill(k: int) -> None:
            if k >= session.cycles // 4 and recorder.trace is not None:
                recorder.trace.file.close()
                recorder.trace.file = FullDisk()

        session.start()
        summary = session.run(progress=fill)
        run_dir = recorder.dir
    reason = summary["safe_stop_reason"]
    assert reason is not None and "trace.asc: No space left on device" in reason, reason
    assert summary["stop_confirmed"] is True  # the stop's frames went out: the bus lived on
    assert json.loads((run_dir / "summary.json").read_text())["safe_stop_reason"] == reason


def test_write_atomic_leaves_the_old_file_or_the_new_one(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "summary.json"
    path.write_text("old")

    def half(f: object) -> None:
        f.write("ne")  # type: ignore[attr-defined]
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(OSError, match="No space left on device"):  # the writer's own error
        write_atomic(path, half)
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"]
    write_atomic(path, lambda f: f.write("new"))
    assert path.read_text() == "new"


def test_rig_run_on_a_full_disk_is_a_safe_stop_with_its_summary(tmp_path: pathlib.Path) -> None:
    limit = 256 * 1024  # [bytes] the trace passes it within the first second

    def small_files() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of the signal
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    config = tmp_path / "rig.toml"
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path / "runs"}"')
    config.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "rig.cli", "run", "--config", str(config), "--emulate", "--json"],
        capture_output=True,
        check=False,
        text=True,
        timeout=300,
        preexec_fn=small_files,
        cwd=ROOT,
    )
    assert proc.returncode == 6, proc.stderr[-2000:]  # a file of the run cut short
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
    summary = json.loads(proc.stdout)
    assert "File too large" in summary["safe_stop_reason"], summary
    assert summary["stop_confirmed"] is True
    assert summary["files_not_written"] == ["trace.asc"] and summary["samples_not_written"] == 0
    run_dir = pathlib.Path(summary["run_dir"])
    assert json.loads((run_dir / "summary.json").read_text())["cycles"] == summary["cycles"]
    assert (run_dir / "trace.asc").read_text().endswith("\n")  # no torn line


def test_a_full_disk_at_the_close_keeps_the_whole_rows(tmp_path: pathlib.Path) -> None:
    """The disk fills while samples.csv still has rows in its buffer: the close neither raises
    (no seek or close retries the refused flush into a traceback) nor reads a torn row; the
    summary lists what could not be written (found by the disk-full scenario on a 512 KiB
    tmpfs: a traceback at the close, no summary)."""
    from rig.host.recorder import Recorder

    recorder = Recorder(str(tmp_path), "full", flush_period=1e9)  # the buffer is flushed at the close
    recorder.begin(["t", "x"])
    for k in range(20_000):
        recorder.sample([k * 1e-3, 1.0 + k])
    on_disk = (recorder.dir / "samples.csv").stat().st_size
    limit = on_disk + 1000  # the close's flush passes it mid-row
    old_handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        summary: dict[str, object] = {"cycles": 20_000}
        recorder.close(summary)  # must not raise
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, old_handler)
    assert any("samples.csv" in w for w in summary["warnings"]), summary  # type: ignore[attr-defined]
    rows = (recorder.dir / "samples.csv").read_text().splitlines()[1:]
    assert 0 < len(rows) < 20_000
    whole = [r for r in rows if r.count(",") == 1]
    assert len(whole) >= len(rows) - 1  # at most the last one torn on disk
    assert json.loads((recorder.dir / "summary.json").read_text())["cycles"] == 20_000
