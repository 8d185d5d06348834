"""``rig run --view`` costs the run's process a ring write a cycle (issue 38 item 2): the recorder
writes each row into memory shared with the view's process (``rig.live.shared_ring``), which reads
it there (``rig.view.ring_pump``); the run's process has no thread of the view's and sends three
messages a run over the pipe, none per update; the recorder's files are the same; a view process
that has died costs the run nothing. Lock-step, no clock decides anything."""

from __future__ import annotations

import json
import multiprocessing
import os
import pathlib
import threading
from typing import Any

import numpy as np
import pytest

from rig.config import load_config
from rig.host.recorder import Recorder
from rig.host.session import run_config
from rig.live.ring_states import StateColumns, state_words
from rig.live.shared_ring import RingReader, SharedRing
from tests.patching import stand_in

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
DYNO = EXAMPLES / "dyno_speed_load.toml"
TIMING = 3  #: the stage times ending each row of samples.csv (not in the live rows)


def _reader(ring: SharedRing) -> RingReader:
    assert ring.fd is not None
    return RingReader(os.dup(ring.fd), ring.layout)


def test_a_reader_overtaken_gets_only_rows_not_overwritten_in_order_and_counts_the_lost() -> None:
    ring = SharedRing(8, 2)
    reader = _reader(ring)
    for k in range(3):
        ring.append((k * 1e-3, float(k)))
    rows, lost = reader.read()
    assert rows[:, 0].tolist() == [0, 1, 2] and rows[:, 2].tolist() == [0.0, 1.0, 2.0] and lost == 0
    for k in range(3, 53):  # 50 more rows into 8 slots
        ring.append((k * 1e-3, float(k)))
    rows, lost = reader.read()
    # the slot of row 45 is row 53's, which the writer may be writing: 46..52 are sure
    assert rows[:, 2].tolist() == [float(k) for k in range(46, 53)] and lost == 43

    class Overtaking:  # the writer runs on while the reader copies: 5 rows before the copy is taken
        def __init__(self, rows: np.ndarray) -> None:
            self.rows = rows

        def __getitem__(self, index: Any) -> np.ndarray:
            for k in range(64, 69):
                ring.append((k * 1e-3, float(k)))
            return self.rows[index]

    for k in range(53, 64):  # the ring holds 56..63; the reader's count says 64
        ring.append((k * 1e-3, float(k)))
    reader._rows = Overtaking(reader._rows)  # type: ignore[assignment]
    rows, lost = reader.read()
    # then 69 after the copy: the slots of 56..60 hold 64..68, that of 61 row 69's to come
    assert rows[:, 2].tolist() == [62.0, 63.0] and lost == 64 - 53 - 2
    assert reader.lost == 43 + lost and reader.next == 64
    assert np.all(np.diff(rows[:, 1]) > 0)


class _Slot:
    def __init__(self) -> None:
        self.timestamp: float | None = None
        self.word = 0

    def values(self) -> tuple[int, ...]:
        return (123, self.word)


class _Axis:
    def __init__(self, name: str, slot: _Slot | None) -> None:
        self.name, self.fault = name, None
        self.data = None if slot is None else type("D", (), {"where": lambda _, key: (slot, 1)})()


def test_the_loop_writes_the_axes_states_and_the_reader_tells_them_in_words() -> None:
    slot = _Slot()
    axes: list[Any] = [_Axis("motor", slot), _Axis("load", None)]
    ring = SharedRing(16, 1, axes)
    reader = _reader(ring)
    ring.append((0.0,))  # no TPDO yet
    slot.timestamp, slot.word = 1.0, 0x0637  # OPERATION ENABLED
    ring.append((0.001,))
    axes[0].fault = RuntimeError("node 1: EMCY 0x2310 (over-current)")
    axes[1].fault = RuntimeError("lost")
    slot.word = 0x0618  # FAULT
    ring.append((0.002,))
    rows, _ = reader.read()
    names = ["motor", "load"]
    said = [state_words(r[2:].tolist(), names, reader.texts) for r in rows]
    assert said[0] == {
        "motor": {"state": "running", "fault": None, "statusword": None},
        "load": {"state": "running", "fault": None, "statusword": None},
    }
    assert said[1]["motor"] == {"state": "OPERATION ENABLED", "fault": None, "statusword": 0x0637}
    assert said[2] == {
        "motor": {"state": "FAULT", "fault": "node 1: EMCY 0x2310 (over-current)", "statusword": 0x0618},
        "load": {"state": "fault", "fault": "lost", "statusword": None},
    }
    assert StateColumns([], ring.texts).now() == []


def _dyno(tmp_path: pathlib.Path) -> Any:
    os.chdir(tmp_path)
    return load_config(DYNO)


class _Sink:
    """The view's process's pipe, as the run's process sees it: what was sent, and a reader of
    the ring handed over (as the view's process has it)."""

    def __init__(self) -> None:
        self.sent: list[str] = []
        self.reader: RingReader | None = None
        self.names: list[str] = []

    def open(self, meta: dict[str, Any]) -> None:
        self.sent.append("open")
        self.meta = meta

    def push(self, *args: Any) -> None:
        self.sent.append("rows")

    def ring(self, fd: int, layout: tuple[int, int, int], names: list[str]) -> None:
        from rig.live.shared_ring import Layout

        self.sent.append("ring")
        self.reader, self.names = RingReader(os.dup(fd), Layout(*layout)), names

    def stop(self) -> None:
        self.sent.append("stop")


def test_rig_run_view_has_no_view_thread_in_the_run_s_process_and_sends_nothing_per_update(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``start_beside``'s live view, the view's process replaced by a pipe that keeps what it is
    sent: during the run no thread is started, the pipe gets "open", "ring" and "stop" only, no
    shared memory is left with a name, and the ring holds every row of samples.csv with the
    motor's CiA 402 state."""
    pytest.importorskip("starlette")
    from rig.cli.view import start_beside
    from rig.view.ring_pump import RingPump
    from rig.view.scope import Scope

    sink = _Sink()
    fake = type("Fake", (), {"__init__": lambda self, *a, **k: None, "url": "http://x/", "sink": sink})
    stand_in(monkeypatch, "rig.view.process.ViewProcess", fake)
    cfg = _dyno(tmp_path)
    live, started, _ = start_beside("127.0.0.1:0", cfg)
    shm = pathlib.Path("/dev/shm")
    named = set(shm.iterdir()) if shm.is_dir() else set()
    before = set(threading.enumerate())
    during: list[set[threading.Thread]] = []
    summary = run_config(
        cfg,
        emulate=True,
        duration=0.2,
        progress=lambda k, n: during.append(set(threading.enumerate()) - before),
        live=live,
        started=started,
    )
    assert live.thread is None and during and not set().union(*during)
    assert sink.sent == ["open", "ring", "stop"] and live.rows is None  # let go of at the stop
    assert (set(shm.iterdir()) if shm.is_dir() else set()) == named  # no name: nothing to unlink
    assert sink.reader is not None and sink.names == ["motor", "encoder", "load"]
    want = np.loadtxt(pathlib.Path(summary["run_dir"]) / "samples.csv", delimiter=",", skiprows=1)
    width = len(sink.meta["columns"])
    assert width == want.shape[1] - TIMING
    rows, lost = sink.reader.read()
    assert lost == 0 and len(rows) == summary["cycles"] == len(want)
    np.testing.assert_array_equal(rows[:, 1 : 1 + width], want[:, :width])
    scope = Scope()
    scope.open(sink.meta)
    sink.reader.next = 0  # read it again, as the view's process does
    assert RingPump(scope, sink.reader, sink.names, 30.0).pump() == len(want)
    assert scope.states["motor"]["state"] == "OPERATION ENABLED" and scope.states["motor"]["fault"] is None
    assert scope.states["encoder"]["state"] == "running"


def _files(run_dir: pathlib.Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(run_dir.iterdir()) if p.name != "started.json"}


def test_the_recorder_s_files_are_the_same_byte_for_byte_with_the_ring(tmp_path: pathlib.Path) -> None:
    rng = np.random.default_rng(38)
    data = rng.normal(size=(500, 4)).tolist()
    dirs = []
    for name, ring in (("plain", None), ("ring", SharedRing(64, 4))):
        rec = Recorder(tmp_path / name, "r", trace=False)
        rec.PLOT = False
        rec.begin(["t", "reference", "measurement", "command"], {"t": {"unit": "s", "meaning": "time"}})
        rec.live = ring
        for k, row in enumerate(data):
            rec.sample([k * 1e-3, *row[1:]], (1.0, 2.0, 3.0))
        rec.close({"cycles": len(data)})
        dirs.append(rec.dir)
        if ring is not None:
            assert ring.published == len(data) and ring.failed is None
    plain, shared = (_files(d) for d in dirs)
    assert set(plain) == set(shared) and "samples.csv" in plain
    for name in plain:
        assert plain[name] == shared[name], name


def test_a_view_process_that_has_died_costs_the_run_nothing(tmp_path: pathlib.Path) -> None:
    """The view's process gone before the run begins (its end of the pipe closed): the run's
    messages and the ring's descriptor go nowhere, logged once; the run's rows are a plain run's."""
    pytest.importorskip("starlette")
    from rig.view.beside import SharedView
    from rig.view.process import PipeSink

    cfg = _dyno(tmp_path)
    ours, theirs = multiprocessing.Pipe()
    theirs.close()
    sink = PipeSink(ours)
    live = SharedView(sink, cfg.run.output)
    summary = run_config(cfg, emulate=True, duration=0.1, live=live, started=live.watch)
    plain = run_config(cfg, emulate=True, duration=0.1)
    assert sink.failed and summary["safe_stop_reason"] is None and summary["cycles"] == plain["cycles"]
    got, want = (
        np.loadtxt(pathlib.Path(s["run_dir"]) / "samples.csv", delimiter=",", skiprows=1)
        for s in (summary, plain)
    )
    np.testing.assert_array_equal(got[:, :-TIMING], want[:, :-TIMING])
    assert json.loads((pathlib.Path(summary["run_dir"]) / "columns.json").read_text()) == json.loads(
        (pathlib.Path(plain["run_dir"]) / "columns.json").read_text()
    )
