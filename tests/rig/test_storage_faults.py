"""Storage faults across processes: ``rig run`` on a full disk and in a directory that turns read-only.

Each ``rig run --emulate`` is a process of its own (lock-step: deterministic). The full disk is
a real one where this process may mount (a tmpfs of 512 KiB: ENOSPC as on any full disk);
elsewhere those tests are skipped (``test_storage.py`` has the file-size limit, EFBIG, which
needs no privilege). The read-only directory is a real ``chmod 555`` of the run directory, made
as the cycles start; a process of root keeps its write access (CAP_DAC_OVERRIDE) unless those
capabilities are dropped first, which the child does.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import pathlib
import subprocess
import sys
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from rig.faults.wire import without_write_override
from rig.host.storage import RowFile

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "dc_servo_position.toml"


def _config(tmp_path: pathlib.Path, output: pathlib.Path) -> pathlib.Path:
    config = tmp_path / "rig.toml"
    config.write_text(EXAMPLE.read_text().replace('output = "runs"', f'output = "{output}"'))
    return config


def _rig_run(config: pathlib.Path, *, code: str = "", preexec: Callable[[], None] | None = None) -> Any:
    """``rig run --config CONFIG --emulate --json`` in a process of its own (``code`` run first)."""
    script = f"{code}\nimport sys\nfrom rig.cli import main\nsys.exit(main(sys.argv[1:]))"
    args = ["run", "--config", str(config), "--emulate", "--json"]
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        capture_output=True,
        check=False,
        text=True,
        timeout=300,
        cwd=ROOT,
        preexec_fn=preexec,
    )


@contextlib.contextmanager
def _tmpfs(path: pathlib.Path, size: str) -> Iterator[pathlib.Path]:
    path.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root (the file-size limit test needs none)")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)], check=False)
    if done.returncode != 0:
        pytest.skip("this machine does not let root mount a tmpfs")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], check=False)


def _whole_rows(csv: pathlib.Path) -> int:
    """The rows of ``csv`` (the header not counted), each checked whole: as many fields as the
    header, every one a number, the file ending in a newline."""
    text = csv.read_text()
    assert text.endswith("\n"), repr(text[-80:])
    head, *rows = text.splitlines()
    width = head.count(",") + 1
    for line in rows:
        fields = line.split(",")
        assert len(fields) == width, line
        [float(v) for v in fields]
    return len(rows)


def test_row_file_cuts_a_torn_row_and_keeps_the_rest_for_later(tmp_path: pathlib.Path) -> None:
    """A disk that refuses part of a flush (here a file-size limit: EFBIG mid-row, as ENOSPC
    would be) leaves whole rows on disk; the rows refused are kept and written at the next flush."""
    import resource
    import signal

    rows = RowFile(tmp_path / "samples.csv")
    lines = [f"{k},{k * 0.5!r},{-k!r}\n" for k in range(2000)]
    for line in lines[:1000]:
        rows.write(line)
    rows.flush()
    limit = rows.size + 5000 + 7  # the next flush passes it in the middle of a row
    old = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        for line in lines[1000:]:
            rows.write(line)
        with pytest.raises(OSError) as refused:
            rows.flush()
        assert refused.value.errno == errno.EFBIG, refused.value  # the file size limit's
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, old)
    on_disk = (tmp_path / "samples.csv").read_text()
    assert on_disk.endswith("\n") and rows.size == len(on_disk) < limit
    assert on_disk.splitlines() == [line.rstrip("\n") for line in lines[: rows.lines]]
    assert rows.unwritten == 2000 - rows.lines > 0
    rows.close()  # room again: the rest goes on
    assert (tmp_path / "samples.csv").read_text() == "".join(lines) and rows.unwritten == 0


def test_rig_run_on_a_full_disk_keeps_every_row_whole_and_writes_its_summary(tmp_path: pathlib.Path) -> None:
    """A 512 KiB tmpfs fills within the first 0.3 s of the run: a safe stop; every cycle's row is
    on disk whole, summary.json, samples.mat and plot.png are there (room was held for them),
    trace.asc ends at a whole line and is named as cut short; exit code 6."""
    with _tmpfs(tmp_path / "disk", "512k") as disk:
        proc = _rig_run(_config(tmp_path, disk / "runs"))
        assert proc.returncode == 6, proc.stderr[-3000:]
        assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
        summary = json.loads(proc.stdout)
        assert "No space left on device" in summary["safe_stop_reason"], summary
        assert summary["stop_confirmed"] is True
        run_dir = pathlib.Path(summary["run_dir"])
        assert _whole_rows(run_dir / "samples.csv") == summary["cycles"] > 0
        assert summary["samples_not_written"] == 0
        assert summary["files_not_written"] == ["trace.asc"], summary
        assert json.loads((run_dir / "summary.json").read_text()) == summary
        assert (run_dir / "samples.mat").stat().st_size > 0 and (run_dir / "plot.png").stat().st_size > 0
        assert (run_dir / "trace.asc").read_text().endswith("\n")
        assert "not written whole" in proc.stderr and "trace.asc" in proc.stderr


def test_rig_run_on_a_disk_too_full_for_its_summary_prints_it_with_the_samples_lost(
    tmp_path: pathlib.Path,
) -> None:
    """The disk has 64 KiB left when the run starts (no room to hold any back): the summary
    cannot be written, so it is printed, naming every file not written and counting the
    samples not on disk; the rows that are on disk are whole."""
    with _tmpfs(tmp_path / "disk", "512k") as disk:
        filler = disk / "filler"
        with contextlib.suppress(OSError), filler.open("wb") as f:
            f.write(b"\0" * (512 - 64) * 1024)
        proc = _rig_run(_config(tmp_path, disk / "runs"))
        assert proc.returncode == 6, proc.stderr[-3000:]
        assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
        summary = json.loads(proc.stdout)
        run_dir = pathlib.Path(summary["run_dir"])
        assert "summary.json" in summary["files_not_written"], summary
        assert not (run_dir / "summary.json").exists()
        missing = [name for name in ("samples.mat", "plot.png") if not (run_dir / name).exists()]
        assert set(missing) <= set(summary["files_not_written"])
        rows = _whole_rows(run_dir / "samples.csv")
        assert rows + summary["samples_not_written"] == summary["cycles"], summary
        assert "the summary printed here is its only copy" in proc.stderr, proc.stderr[-2000:]


#: the run directory made read-only as the cycles start (after started.json): samples.csv and
#: trace.asc are open already and go on; nothing new can be made in it
_READ_ONLY_AT_START = """
import os
from rig.host.recorder import Recorder
_mark_start = Recorder.mark_start
def mark_start(self):
    _mark_start(self)
    os.chmod(self.dir, 0o555)
Recorder.mark_start = mark_start
"""


def test_a_run_directory_that_turns_read_only_exits_non_zero_naming_each_file(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "runs"
    proc = _rig_run(_config(tmp_path, out), code=_READ_ONLY_AT_START, preexec=without_write_override)
    try:
        assert proc.returncode == 6, proc.stderr[-3000:]
        assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
        summary = json.loads(proc.stdout)
        assert summary["safe_stop_reason"] is None and summary["stop_confirmed"] is True
        assert summary["files_not_written"] == ["samples.mat", "plot.png", "summary.json"], summary
        assert summary["samples_not_written"] == 0
        run_dir = pathlib.Path(summary["run_dir"])
        assert _whole_rows(run_dir / "samples.csv") == summary["cycles"] > 0
        assert sorted(p.name for p in run_dir.iterdir()) == [
            "columns.json",
            "config.json",
            "samples.csv",
            "started.json",
            "trace.asc",
        ]
        line = next(x for x in proc.stderr.splitlines() if "not written whole" in x)
        assert "samples.mat, plot.png, summary.json" in line and str(run_dir) in line, line
        assert any("Permission denied" in w for w in summary["warnings"]), summary["warnings"]
    finally:
        for d in out.glob("*"):
            d.chmod(0o755)
