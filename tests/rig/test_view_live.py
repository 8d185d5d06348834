"""The live scope (issue 38 items 1-3): fed from the recorder's ring off the control thread (read in
the view's own process), decimated for the screen, the run's summary at its end; ``rig run
--view`` across processes, with a thousand idle websockets and hostile requests beside it, ends as
the same run without a view; and ``rig run`` without ``--view`` imports no web framework."""

from __future__ import annotations

import asyncio
import json
import os
import pathlib
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from typing import Any

import numpy as np
import pytest

pytest.importorskip("starlette")
pytest.importorskip("websockets")

from rig.config import load_config
from rig.host.session import run_config
from rig.live.shared_ring import RingReader, SharedRing
from rig.view.app import MAX_LIVE
from rig.view.feed import TailFeed, live_meta
from rig.view.ring_pump import RingPump
from rig.view.scope import HISTORY, MOST, Scope, decimate

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
DYNO = EXAMPLES / "dyno_speed_load.toml"


def test_decimation_keeps_each_column_s_extremes() -> None:
    t = np.arange(5000) * 1e-4
    rows = np.column_stack([t, np.sign(np.sin(2e3 * t)), np.cos(t)])
    rows[1234, 2] = 9.0  # a spike one row wide
    small = decimate(rows)
    assert len(small) <= MOST and small[:, 2].max() == 9.0 and small[:, 1].min() == -1.0
    assert np.all(np.diff(small[:, 0]) >= 0)
    assert decimate(rows[:10]) is not None and len(decimate(rows[:10])) == 10


def test_the_ring_pump_sends_only_new_rows_and_the_states(tmp_path: pathlib.Path) -> None:
    """The view's process's reader of the run's shared ring: the run's description from its files
    (the stage times, a real-time run's response parts too, are not in the ring's rows), each
    update's new rows and the axes' states, the summary at the end."""
    run = tmp_path / "r"
    run.mkdir()
    columns = ("t", "u", "late", "read_us", "update_us", "write_us", "answer_us", "host_us")
    (run / "columns.json").write_text(json.dumps({c: {"unit": "s" if c == "t" else "V"} for c in columns}))
    scope = Scope()
    scope.open(live_meta(run, "r"))
    assert [c["name"] for c in scope.meta["columns"]] == ["t", "u", "late"]  # type: ignore[index]
    ring = SharedRing(64, 3)
    assert ring.fd is not None
    pump = RingPump(scope, RingReader(os.dup(ring.fd), ring.layout), [], 30.0)
    first = [(k * 1e-3, float(k), 0.0) for k in range(10)]
    for row in first:
        ring.append(row)
    assert pump.pump() == 10
    seq, message = scope.since(0)
    assert message is not None and json.loads(message)["rows"] == [list(r) for r in first]
    ring.append((0.010, 10.0, 0.0))
    ring.append((0.011, float("nan"), 1.0))
    pump.pump()
    seq, message = scope.since(seq)
    assert json.loads(message or "")["rows"] == [[0.010, 10.0, 0.0], [0.011, None, 1.0]]
    assert scope.since(seq)[1] is None  # nothing new
    pump.stop()
    assert scope.stopped and not scope.done.is_set()
    scope.finish({"cycles": 12, "rms_error": float("inf")})
    assert json.loads(scope.end_message() or "") == {
        "type": "end",
        "summary": {"cycles": 12, "rms_error": None},
    }
    hello = json.loads(scope.hello()[1])
    assert len(hello["rows"]) == 12 and hello["summary"]["cycles"] == 12


def test_a_late_browser_gets_the_history_decimated() -> None:
    scope = Scope(keep=5.0)
    scope.open({"title": "x", "columns": [], "charts": []})
    for k in range(100):  # 10 s of 1 kHz rows in updates of 100 rows
        t = (np.arange(100) + 100 * k) * 1e-3
        scope.push(np.column_stack([t, t]))
    rows = json.loads(scope.hello()[1])["rows"]
    assert len(rows) <= HISTORY and 9.99 <= rows[-1][0] <= 9.999 and rows[0][0] >= 4.9


def test_the_tail_waits_for_a_summary_still_being_written(tmp_path: pathlib.Path) -> None:
    """A summary.json that is there but half-written (a writer that does not replace it
    atomically) is read again until it parses: the scope ends with it, not with an empty one."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "samples.csv").write_text("t,reference\n0.0,1.0\n")
    (run / "summary.json").write_text('{"cycles": 1, ')
    scope = Scope()
    tail = TailFeed(scope, run, rate=200.0)
    tail.start()
    try:
        deadline = time.monotonic() + 30.0
        while scope.seq == 0 and time.monotonic() < deadline:  # the rows read, the summary torn
            time.sleep(0.001)
        (run / "summary.tmp").write_text('{"cycles": 1, "safe_stop_reason": null}')
        (run / "summary.tmp").replace(run / "summary.json")
        assert scope.done.wait(30.0)
    finally:
        tail.stop()
    assert json.loads(scope.hello()[1])["summary"] == {"cycles": 1, "safe_stop_reason": None}


def test_the_tail_follows_a_run_directory(tmp_path: pathlib.Path) -> None:
    """``rig view RUN_DIR``: rows as samples.csv grows; the summary once summary.json is there."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "samples.csv").write_text("t,reference\n0.0,1.0\n0.001,2.0\n0.002,")  # a torn row
    scope = Scope()
    tail = TailFeed(scope, run, rate=200.0)
    tail.start()
    try:
        with (run / "samples.csv").open("a") as f:
            f.write("3.0\n0.003,4.0\n")
        (run / "summary.json").write_text('{"cycles": 4, "safe_stop_reason": null}')
        assert scope.done.wait(30.0)
    finally:
        tail.stop()
    hello = json.loads(scope.hello()[1])
    assert hello["rows"] == [[0.0, 1.0], [0.001, 2.0], [0.002, 3.0], [0.003, 4.0]]
    assert hello["summary"] == {"cycles": 4, "safe_stop_reason": None}


def test_rig_run_without_view_imports_no_web_framework(tmp_path: pathlib.Path) -> None:
    code = (
        "import sys; from rig.cli import main; "
        f"rc = main(['run', '--config', {str(DYNO)!r}, '--emulate', '--duration', '0.02']); "
        "print(sorted(m for m in ('starlette', 'uvicorn', 'websockets', 'anyio') if m in sys.modules), rc)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    assert out.stdout.strip().splitlines()[-1] == "[] 0", out.stderr[-2000:]


def _get(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=30) as r:
            r.read()
            return int(r.status)
    except urllib.error.HTTPError as exc:
        exc.close()
        return exc.code


async def _watch_and_attack(base: str, proc: subprocess.Popen[str]) -> dict[str, Any]:
    """A browser-like client reading the scope; a thousand idle websockets and hostile requests
    beside it; then Ctrl-C to the run, and what the client saw until the end."""
    from websockets.asyncio.client import connect
    from websockets.exceptions import InvalidStatus

    ws_url = base.replace("http://", "ws://") + "ws/live"
    seen: dict[str, Any] = {"times": [], "states": None, "end": None, "meta": None}
    watcher = await connect(ws_url, max_size=None)
    seen["meta"] = json.loads(await watcher.recv())["meta"]  # None until the run has begun

    async def read() -> None:
        async for raw in watcher:
            msg = json.loads(raw)
            seen["meta"] = seen["meta"] or msg.get("meta")
            if msg["type"] == "rows" and msg["rows"]:
                seen["times"].append(msg["rows"][-1][0])
                seen["states"] = msg["states"]
            elif msg["type"] == "end":
                seen["end"] = msg["summary"]

    reader = asyncio.ensure_future(read())
    while len(seen["times"]) < 5:
        await asyncio.sleep(0.05)
    before = len(seen["times"])

    async def idle() -> str:
        try:
            sock = await connect(ws_url, open_timeout=60)
        except InvalidStatus as exc:
            return str(exc.response.status_code)
        except OSError as exc:
            return type(exc).__name__
        idle_sockets.append(sock)  # held open, never read
        return "open"

    idle_sockets: list[Any] = []
    outcomes = await asyncio.gather(*(idle() for _ in range(1000)))
    loop = asyncio.get_running_loop()
    hostile = [
        base + "api/runs/0/..%2F..%2F..%2Fetc%2Fpasswd",
        base + "static/%2E%2E/%2E%2E/%2E%2E/etc/passwd",
        base + "api/runs?q=" + "x" * 100_000,
        base + "api/runs/0/x/samples?points=" + "9" * 50,
    ]
    statuses = [await loop.run_in_executor(None, _get, url) for url in hostile]
    while len(seen["times"]) < before + 10:  # the watcher goes on being fed
        await asyncio.sleep(0.05)
    seen["running"] = seen["states"]  # the drives' states the scope showed while the run went on
    proc.send_signal(signal.SIGINT)
    await asyncio.wait_for(reader, 120)
    for sock in idle_sockets:
        await sock.close()
    return {**seen, "outcomes": outcomes, "statuses": statuses, "after": len(seen["times"]) - before}


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_rig_run_view_across_processes_under_attack_ends_as_the_run_without(tmp_path: pathlib.Path) -> None:
    argv = ["run", "--config", str(DYNO), "--emulate", "--duration", "600", "--view", "127.0.0.1:0", "--json"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "rig.cli", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        assert line.startswith("rig run: view at http://127.0.0.1:"), line
        seen = asyncio.run(_watch_and_attack(line.split()[4], proc))
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    # stopped by a signal: 128 + SIGINT, no result printed (docs/cli.md); the view had the summary
    assert proc.returncode == 128 + signal.SIGINT and not out.strip(), err[-2000:]
    assert seen["end"] is not None, err[-2000:]
    summary = json.loads((tmp_path / seen["end"]["run_dir"] / "summary.json").read_text())
    assert summary["safe_stop_reason"] == "Ctrl-C (SIGINT)"
    # the scope: its description, advancing times, the drives' states, the summary at the end
    charts = [c["axis"] for c in seen["meta"]["charts"]]
    assert charts == ["motor", "encoder", "load", "loop"]
    assert seen["after"] >= 10 and seen["times"] == sorted(seen["times"])
    running = seen["running"]["motor"]
    assert running["state"] == "OPERATION ENABLED" and running["fault"] is None, running
    assert (
        seen["end"]["cycles"] == summary["cycles"]
        and seen["end"]["safe_stop_reason"] == summary["safe_stop_reason"]
    )
    # the attack: at most MAX_LIVE sockets (the watcher's among them), the others refused
    assert seen["outcomes"].count("open") <= MAX_LIVE - 1
    assert set(seen["outcomes"]) <= {"open", "403", "503"} and "403" in seen["outcomes"]
    assert all(s in (400, 404, 414) for s in seen["statuses"]), seen["statuses"]
    # the run: the same rows as a run without a view, as far as it went (lock-step is deterministic)
    got = np.loadtxt(pathlib.Path(tmp_path, summary["run_dir"]) / "samples.csv", delimiter=",", skiprows=1)
    cfg = load_config(DYNO)
    os.chdir(tmp_path)
    plain = run_config(cfg, emulate=True, duration=summary["cycles"] * cfg.period)
    want = np.loadtxt(pathlib.Path(plain["run_dir"]) / "samples.csv", delimiter=",", skiprows=1)
    n = summary["cycles"] - 1  # the interrupted cycle's row may be the stop's
    np.testing.assert_array_equal(got[:n, :-3], want[:n, :-3])


def _nice_and_cpus(tid: int) -> tuple[int, set[int]]:
    """A thread's niceness and CPUs, as the kernel has them."""
    stat = pathlib.Path(f"/proc/self/task/{tid}/stat").read_text()
    return int(stat[stat.rindex(")") + 2 :].split()[16]), os.sched_getaffinity(tid)


@pytest.mark.skipif(not pathlib.Path("/proc/self/task").is_dir(), reason="Linux's per-thread scheduling")
def test_the_view_s_process_steps_aside_from_the_loop() -> None:
    """The view's process (``serve_child``, and each thread it starts: the server's, uvicorn's)
    runs at nice 10 and off the loop's CPU, so the browsers' requests never take that CPU and the
    machine's other work comes first; without a pinned loop, on every CPU. Done in a thread here:
    Linux schedules threads one by one, and a thread started after inherits."""
    from rig.view.process import NICE, step_aside

    cpus = os.sched_getaffinity(0)
    before = _nice_and_cpus(threading.get_native_id())
    loop = max(cpus)
    seen: dict[str, tuple[int, set[int]]] = {}

    def aside(pinned: int | None) -> None:
        step_aside(pinned)
        later = threading.Thread(
            target=lambda: seen.update({str(pinned): _nice_and_cpus(threading.get_native_id())})
        )
        later.start()
        later.join()

    for pinned in (loop, None):
        thread = threading.Thread(target=aside, args=(pinned,))
        thread.start()
        thread.join(30.0)
    assert seen[str(loop)] == (NICE, cpus - {loop} or cpus)
    assert seen["None"] == (NICE, cpus)
    assert _nice_and_cpus(threading.get_native_id()) == before  # the caller's own: untouched
