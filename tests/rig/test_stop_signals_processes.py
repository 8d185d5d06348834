"""Signals, one rule, across real processes (docs/cli.md, "Exit codes and stop signals"): each
command started as a script's background job starts it (SIGINT ignored, SIGTERM blocked by the
parent), through the installed console script ``rig`` or ``python -m rig.cli``, gets SIGINT or
SIGTERM once it is under way (its first run's started.json, its first row, its first line) and
must be gone within 2 s, with 128 + the signal's number, no result on stdout and its one line
on stderr; ``rig emulate &`` from ``sh -c`` ends with 0. Timing tier: the 2 s are wall clock.
The rule itself, deterministically: ``test_stop_signals.py``.
"""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence

import pytest

from rig.emulator.spawn import spawn_emulator, stop_rig
from rig.faults.wire_probe import wait_for

pytestmark = pytest.mark.timing

ROOT = pathlib.Path(__file__).resolve().parents[2]
SERVO = ROOT / "examples" / "dc_servo_position.toml"
RIG = pathlib.Path(sys.executable).parent / "rig"  #: the console script, as pip installed it
BUDGET = 2.0  #: [s] from the signal to the process's end
CONFIRMED = "every drive stopped, at rest and disabled"


def _entry(script: bool) -> list[str]:
    if script and not RIG.is_file():
        pytest.skip(f"no console script {RIG} (pip install -e . makes it)")
    return [str(RIG)] if script else [sys.executable, "-m", "rig.cli"]


def _as_a_background_job() -> None:
    """preexec_fn: what a non-interactive shell gives a background job (SIGINT ignored), and a
    parent that blocks SIGTERM (the mask survives exec)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})


class Command:
    """``rig ARGS`` in ``tmp`` (its TMPDIR there too), stdout and stderr to files."""

    def __init__(self, tmp: pathlib.Path, argv: Sequence[str], *, group: bool = False) -> None:
        self.tmp = tmp
        (tmp / "tmp").mkdir(exist_ok=True)
        self.out, self.err = tmp / "out.txt", tmp / "err.txt"
        with self.out.open("w") as out, self.err.open("w") as err:
            self.proc = subprocess.Popen(
                list(argv),
                stdout=out,
                stderr=err,
                cwd=tmp,
                env={**os.environ, "PYTHONUNBUFFERED": "1", "TMPDIR": str(tmp / "tmp")},
                preexec_fn=_as_a_background_job,  # noqa: PLW1509
                start_new_session=group,
            )

    def under_way(self, ready: Callable[[], bool], what: str) -> None:
        wait_for(lambda: ready() or self.proc.poll() is not None, 120.0, what)
        assert self.proc.poll() is None, f"ended before the signal: {self.err.read_text()[-3000:]}"

    def files(self, pattern: str) -> bool:
        return any(self.tmp.glob(pattern))

    def stop(self, sig: signal.Signals) -> tuple[int, float, str, str]:
        """Send ``sig``; (exit code, seconds to the end, stdout, stderr)."""
        t0 = time.monotonic()
        self.proc.send_signal(sig)
        try:
            code = self.proc.wait(timeout=60)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()
        return code, time.monotonic() - t0, self.out.read_text(), self.err.read_text()


def _connected(port: int) -> bool:
    """A TCP connection to ``port`` of this machine is established (/proc/net/tcp)."""
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as f:
            for line in f.readlines()[1:]:
                local, state = line.split()[1], line.split()[3]
                if int(local.rsplit(":", 1)[1], 16) == port and state == "01":
                    return True
    return False


def _cpu_seconds(pid: int) -> float:
    """The CPU time [s] process ``pid`` has had (user and system; 0 once it has ended)."""
    try:
        fields = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _alive_in_group(pgid: int) -> list[int]:
    """The processes of group ``pgid`` not yet ended (a zombie left to init to reap has ended)."""
    alive = []
    for stat in pathlib.Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            alive.append(int(stat.parent.name))
    return alive


def _group_ended(pgid: int, within: float = 10.0) -> list[str]:
    """The command lines of group ``pgid``'s processes still running ``within`` [s] after its
    leader ended (a helper process that ends on its parent's exit, as multiprocessing's resource
    tracker does when its pipe closes, may take a moment: a guard, not a figure)."""
    deadline = time.monotonic() + within
    while (left := _alive_in_group(pgid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    lines = []
    for pid in left:
        try:
            lines.append(pathlib.Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode())
        except OSError:
            continue  # ended meanwhile
    return lines


def _stopped(cmd: Command, sig: signal.Signals, who: str, *, moved: bool) -> str:
    code, seconds, out, err = cmd.stop(sig)
    words = {signal.SIGINT: "Ctrl-C (SIGINT)", signal.SIGTERM: "SIGTERM (terminate)"}[sig]
    said = err.strip().splitlines()[-1]
    print(f"{who}: {seconds:.2f} s from {sig.name} to its end, exit {code}")
    assert code == 128 + sig, err[-3000:]
    assert seconds < BUDGET, (seconds, err[-3000:])
    assert out == "", out  # no result, not even part of one
    assert "Traceback" not in err, err[-3000:]
    assert said.startswith(f"{who}: stopped by {words}" + (f"; {CONFIRMED}" if moved else "")), said
    return said


@pytest.mark.parametrize(
    ("script", "sig"), [(True, signal.SIGINT), (False, signal.SIGTERM)], ids=["rig-sigint", "m-sigterm"]
)
def test_rig_run(tmp_path: pathlib.Path, script: bool, sig: signal.Signals) -> None:
    argv = ["run", "--config", str(SERVO), "--emulate", "--duration", "600"]
    cmd = Command(tmp_path, [*_entry(script), *argv])
    cmd.under_way(lambda: cmd.files("runs/*/started.json"), "the run's start")
    said = _stopped(cmd, sig, "rig run", moved=True)
    (run_dir,) = tmp_path.glob("runs/*")
    assert said.endswith(f"what was done is in runs/{run_dir.name}") and (run_dir / "summary.json").is_file()


def test_rig_drive_jog(tmp_path: pathlib.Path) -> None:
    cmd = Command(tmp_path, [*_entry(True), "-v", "drive", "--emulate", "epos4", "jog", "5", "--for", "60"])
    cmd.under_way(lambda: "0x60FF" in cmd.err.read_text(), "the jog's target velocity")
    _stopped(cmd, signal.SIGINT, "rig drive jog", moved=True)


def test_rig_identify(tmp_path: pathlib.Path) -> None:
    cmd = Command(tmp_path, [*_entry(False), "identify", "--emulate", "dc-servo", "--duration", "60"])
    cmd.under_way(lambda: cmd.files("runs/*/started.json"), "the experiment's start")
    _stopped(cmd, signal.SIGTERM, "rig identify", moved=True)
    assert not cmd.files("runs/*/identification.json")


def test_rig_reproduce_drives(tmp_path: pathlib.Path) -> None:
    """Was: it went on 19-55 s and printed the cut-short runs as results, exit 0."""
    cmd = Command(tmp_path, [*_entry(True), "reproduce", "drives"])
    cmd.under_way(lambda: cmd.files("tmp/rig-drives-*/*/started.json"), "its first run over the bus")
    _stopped(cmd, signal.SIGINT, "rig reproduce drives", moved=True)


def test_rig_faults(tmp_path: pathlib.Path) -> None:
    """Was: as rig reproduce drives. The signal comes as a scenario's run has started (it may
    have ended by then: then nothing was moving)."""
    cmd = Command(tmp_path, [*_entry(False), "faults"])
    cmd.under_way(lambda: cmd.files("tmp/*/*/*/started.json"), "its first scenario's run")
    _stopped(cmd, signal.SIGINT, "rig faults", moved=False)


def test_rig_demo(tmp_path: pathlib.Path) -> None:
    """Was: exit 1, silently."""
    cmd = Command(tmp_path, [*_entry(True), "demo"])
    cmd.under_way(lambda: cmd.files("runs/*/started.json"), "its identification run")
    _stopped(cmd, signal.SIGTERM, "rig demo", moved=False)


def test_rig_sweep_to_its_client_alone(tmp_path: pathlib.Path) -> None:
    """The signal to ``rig sweep`` only, not its process group: it cancels the points, closes its
    workers (none of its group is left) and names the table of the rows that finished."""
    pytest.importorskip("dask.distributed")
    spec = tmp_path / "spec.toml"
    spec.write_text(
        f'[sweep]\nname = "cut"\nbase = "{SERVO}"\nmetrics = ["rms_error"]\n[fixed]\n"run.duration" = 0.5\n'
        '[parameters]\n"emulator.params.b_m" = { from = 340.0, to = 1360.0, num = 40, scale = "log" }\n'
    )
    cmd = Command(tmp_path, [*_entry(True), "sweep", str(spec), "--workers", "2"], group=True)
    import pyarrow.parquet as pq

    table = tmp_path / "sweeps" / "cut" / "results.parquet"
    cmd.under_way(lambda: table.is_file() and pq.read_table(table).num_rows > 0, "the table's first row")
    said = _stopped(cmd, signal.SIGINT, "rig sweep", moved=False)
    assert said.endswith("what was done is in sweeps/cut/results.parquet")
    assert _group_ended(cmd.proc.pid) == []  # its workers and nannies: gone with it


def test_rig_bench_loop(tmp_path: pathlib.Path) -> None:
    cmd = Command(tmp_path, [*_entry(True), "bench", "loop"])
    cmd.under_way(lambda: cmd.files("tmp/*/*/started.json"), "its first lock-step run")
    _stopped(cmd, signal.SIGTERM, "rig bench", moved=False)


def test_rig_reproduce_dq_current_a_pure_computation(tmp_path: pathlib.Path) -> None:
    """No run, no file: under way once it has had 0.8 s of CPU (its imports take about 0.3 s)."""
    cmd = Command(tmp_path, [*_entry(False), "reproduce", "dq-current"])
    cmd.under_way(lambda: _cpu_seconds(cmd.proc.pid) >= 0.8, "0.8 s of its CPU")
    _stopped(cmd, signal.SIGINT, "rig reproduce dq-current", moved=False)


def test_rig_scan_listening_on_a_bus(tmp_path: pathlib.Path) -> None:
    emulator, port = spawn_emulator("--preset", "dc-servo")
    try:
        argv = ["scan", "--interface", "socketcand", "--channel", "can0", "--port", str(port)]
        argv += ["--listen", "60"]
        cmd = Command(tmp_path, [*_entry(False), *argv])
        cmd.under_way(lambda: _connected(port), "its connection to the bus (then it listens 60 s)")
        _stopped(cmd, signal.SIGTERM, "rig scan", moved=False)
    finally:
        stop_rig(emulator, timeout=10)


def test_rig_emulate_as_a_background_job_of_a_script(tmp_path: pathlib.Path) -> None:
    """``rig emulate ... &`` in ``sh -c`` (SIGINT ignored, as the shell gives it), ``kill -INT``:
    it closes its server and exits 0 within 2 s (was: it ignored the signal)."""
    script = (
        f'"{_entry(True)[0]}" emulate --preset dc-servo --port 0 > out.txt 2> err.txt & '
        'echo $!; wait $!; echo "exit $?"'
    )
    sh = subprocess.Popen(["sh", "-c", script], stdout=subprocess.PIPE, text=True, cwd=tmp_path)
    try:
        assert sh.stdout is not None
        pid = int(sh.stdout.readline())
        out = tmp_path / "out.txt"
        wait_for(lambda: out.is_file() and "socketcand://" in out.read_text(), 60.0, "the emulator's line")
        t0 = time.monotonic()
        os.kill(pid, signal.SIGINT)
        sh.wait(timeout=30)  # sh ends as soon as its job has (was: never)
        seconds = time.monotonic() - t0
        ended = sh.stdout.read()
    finally:
        if sh.poll() is None:
            sh.kill()
        sh.wait(timeout=10)
        sh.stdout.close()  # type: ignore[union-attr]
        if "pid" in locals() and os.path.exists(f"/proc/{pid}"):
            os.kill(pid, signal.SIGKILL)
    print(f"rig emulate &: {seconds:.2f} s from SIGINT to its end")
    assert ended.strip() == "exit 0", (tmp_path / "err.txt").read_text()[-3000:]
    assert seconds < BUDGET, seconds
    assert (tmp_path / "out.txt").read_text().splitlines()[-1] == "rig emulate: stopped"
