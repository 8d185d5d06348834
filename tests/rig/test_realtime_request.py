"""Real time asked for and reported (``rig.host.realtime``): what the system grants is taken and
recorded, what it refuses is one warning and the run goes on, and ``release`` gives back what
was taken. The refusals are real: a process of an unprivileged user (no CAP_SYS_NICE, an
RLIMIT_RTPRIO of 0, a small RLIMIT_MEMLOCK)."""

from __future__ import annotations

import dataclasses
import json
import os
import pathlib
import subprocess
import sys
import threading

import pytest

from rig.config import load_config
from rig.host.realtime import RealtimeRequest, cpu_stolen, request
from rig.host.session import run_config

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"
ROOT = pathlib.Path(__file__).resolve().parents[2]

#: imports first: the interpreter's library may not be readable by the user it becomes
_UNPRIVILEGED = """
import json, logging, os, resource
from rig.host.realtime import RealtimeRequest, _libc, request
_libc()
resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536))
os.setgid(65534); os.setuid(65534)
records = []
class Keep(logging.Handler):
    def emit(self, record): records.append(record.getMessage())
logging.getLogger("rig.host.realtime").addHandler(Keep())
grant = request(RealtimeRequest(50, -1, True))
print(json.dumps({"record": grant.record(), "warnings": records, "policy": os.sched_getscheduler(0)}))
"""


@pytest.mark.skipif(
    not hasattr(os, "setuid") or os.geteuid() != 0, reason="needs root to become another user"
)
def test_what_is_refused_is_one_warning_and_the_run_goes_on() -> None:
    out = subprocess.run(
        [sys.executable, "-c", _UNPRIVILEGED],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    result = json.loads(out.stdout)
    record = result["record"]
    assert (
        record["policy"] == "SCHED_OTHER" and record["priority"] == 0 and result["policy"] == os.SCHED_OTHER
    )
    assert record["memory_locked"] is False
    refused = " ".join(record["refused"])
    assert "SCHED_FIFO 50 for the loop thread" in refused and "memory lock" in refused, refused
    assert "PM QoS CPU latency 0 us (/dev/cpu_dma_latency): Permission denied" in refused, refused
    assert record["cpu_latency_us"] is None
    (warning,) = result["warnings"]
    assert warning.startswith("real time not fully granted (normal scheduling") and "SCHED_FIFO 50" in warning


@pytest.mark.skipif(
    os.geteuid() != 0, reason="SCHED_FIFO and mlockall need root (or CAP_SYS_NICE, CAP_IPC_LOCK)"
)
def test_what_is_granted_is_taken_recorded_and_given_back() -> None:
    stop = threading.Event()
    receiver = threading.Thread(target=stop.wait, name="receive", daemon=True)
    receiver.start()
    before = (os.sched_getscheduler(0), os.sched_getaffinity(0))
    try:
        grant = request(RealtimeRequest(50, -1, True), [receiver])
        assert receiver.native_id is not None
        last = max(before[1])
        try:
            assert grant.record() == {
                "policy": "SCHED_FIFO",
                "priority": 50,
                "receive_priority": 51,
                "receive_threads": 1,
                "cpu": last,
                "memory_locked": True,
                "cpu_latency_us": 0,
                "cpu_latency_in_force_us": 0,
                "refused": [],
            }
            assert os.sched_getscheduler(0) == os.SCHED_FIFO and os.sched_getparam(0).sched_priority == 50
            assert os.sched_getparam(receiver.native_id).sched_priority == 51
            assert os.sched_getaffinity(0) == os.sched_getaffinity(receiver.native_id) == {last}
        finally:
            grant.release()
        assert (os.sched_getscheduler(0), os.sched_getaffinity(0)) == before
        assert os.sched_getscheduler(receiver.native_id) == os.SCHED_OTHER
    finally:
        stop.set()
        receiver.join()


def test_a_realtime_run_records_its_grant(tmp_path: pathlib.Path) -> None:
    """The summary (and summary.json) says what the run was granted; nothing is left raised."""
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), time="realtime"))
    before = os.sched_getscheduler(0)
    summary = run_config(cfg, emulate=True, duration=0.05)
    assert os.sched_getscheduler(0) == before
    granted = summary["realtime"]
    assert set(granted) >= {"policy", "priority", "cpu", "memory_locked", "refused", "gc_collections"}
    assert granted["bus_read_by"] is None  # the emulated world in this process: no bus of the host's
    if os.path.exists("/proc/stat"):  # Linux says how much CPU time a hypervisor took
        assert granted["cpu_stolen_s"] is not None and granted["cpu_stolen_s"] >= 0.0
    if os.geteuid() == 0:
        assert granted["policy"] == "SCHED_FIFO" and granted["priority"] == 50 and granted["memory_locked"]
    on_disk = json.loads((pathlib.Path(summary["run_dir"]) / "summary.json").read_text())
    assert on_disk["realtime"] == granted


def test_young_garbage_is_collected_only_past_the_threshold() -> None:
    """``collect_young`` (the host loop's slack and the emulator's frames thread, the collector
    disabled): below the threshold nothing runs; past it the young generation is collected and
    cyclic garbage freed."""
    import gc
    import weakref

    from rig.host.realtime import collect_young

    class Node:
        pass

    enabled = gc.isenabled()
    gc.disable()
    try:
        gc.collect()
        a, b = Node(), Node()
        a.other, b.other = b, a  # type: ignore[attr-defined]
        gone = weakref.ref(a)
        del a, b
        assert not collect_young(threshold=10_000)
        assert gone() is not None
        assert collect_young(threshold=1)
        assert gone() is None
        assert gc.get_count()[0] < 10
    finally:
        if enabled:
            gc.enable()


def test_the_emulators_frames_thread_calls_its_idle_hook_after_serving() -> None:
    """The socketcand server's I/O thread calls ``idle`` after each round of serving and sending
    (where ``rig emulate`` collects its young garbage in real time, after a SYNC's answers are
    out, not inside one)."""
    import can

    from drivers.bus import open_bus
    from plant_emulator.lockstep import SyncHub
    from plant_emulator.socketcand_server import SocketcandServer

    hub = SyncHub()
    heard: list[int] = []
    node = hub.bus(queue=False, channel="node")
    node.listeners.append(lambda msg: heard.append(msg.arbitration_id))
    server = SocketcandServer(hub, threading.RLock(), port=0)
    calls: list[int] = []
    server.idle = lambda: calls.append(len(heard))
    server.start()
    try:
        bus = open_bus("socketcand", "can0", host="127.0.0.1", port=server.port)
        try:
            bus.send(can.Message(arbitration_id=0x080, is_extended_id=False, data=b""))
            deadline = threading.Event()
            for _ in range(500):
                if heard and calls and calls[-1] >= 1:
                    break
                deadline.wait(0.01)
        finally:
            bus.shutdown()
    finally:
        server.stop()
        node.shutdown()
    assert heard == [0x080]
    assert calls and calls[-1] == 1  # called after the frame was served


def test_cpu_stolen_reads_the_steal_column(tmp_path: pathlib.Path) -> None:
    """``cpu_stolen``: the eighth number of /proc/stat's ``cpu`` line, in the kernel's ticks, as
    seconds; None where there is no such file or field."""
    stat = tmp_path / "stat"
    stat.write_text("cpu  4781734 964 477641 1669202 24899 0 60670 6684 0 0\ncpu0 1 2 3 4 5 6 7 8 9 10\n")
    assert cpu_stolen(str(stat)) == pytest.approx(6684 / os.sysconf("SC_CLK_TCK"))
    stat.write_text("cpu  1 2 3 4 5 6 7\n")  # a kernel without the steal field
    assert cpu_stolen(str(stat)) is None
    assert cpu_stolen(str(tmp_path / "none")) is None


def _latency_in_force() -> int:
    with open("/dev/cpu_dma_latency", "rb") as f:
        return int.from_bytes(f.read(4), sys.byteorder, signed=True)


@pytest.mark.skipif(
    os.geteuid() != 0 or not os.path.exists("/dev/cpu_dma_latency"), reason="PM QoS needs root and the device"
)
def test_the_cpu_is_kept_awake_while_held_and_let_sleep_after() -> None:
    """The PM QoS request is in force while the grant holds it (the kernel's aggregate, read from
    the device, is the request's 0 us) and gone once released (back to what it was)."""
    before = _latency_in_force()
    grant = request(RealtimeRequest(0, -2, False, cpu_latency=0))
    try:
        assert grant.cpu_latency == 0 and grant.cpu_latency_in_force == 0 and _latency_in_force() == 0
        assert "CPU latency held at 0 us" in grant.describe()
    finally:
        grant.release()
    assert _latency_in_force() == before
    none = request(RealtimeRequest(0, -2, False, cpu_latency=-1))
    assert none.cpu_latency is None and "CPU may sleep" in none.describe() and _latency_in_force() == before
    none.release()


def test_a_refused_pm_qos_request_is_named_and_the_rest_goes_on(tmp_path: pathlib.Path) -> None:
    from rig.host.realtime import Grant, _keep_awake

    grant = Grant(RealtimeRequest())
    _keep_awake(grant, 0, str(tmp_path / "no-such-device"))
    assert grant.cpu_latency is None and grant._qos is None
    (said,) = grant.refused
    assert said.startswith(f"PM QoS CPU latency 0 us ({tmp_path / 'no-such-device'}): No such file")


def test_a_run_that_misses_its_period_says_so() -> None:
    from rig.host.loop_summary import missed_period

    summary = {"realtime": {}, "cycles": 7400, "overruns": 100, "late_cycles": 0}
    said = missed_period(summary, 0.0004)
    assert (
        said is not None
        and "100 of 7500 cycles skipped (1.3 %)" in said
        and "rig doctor --period 0.0004" in said
    )
    assert missed_period(summary | {"overruns": 75, "cycles": 7425}, 0.0004) is None  # 1 %: at the bound
    both = missed_period(summary | {"overruns": 40, "cycles": 7460, "late_cycles": 40}, 0.0004)
    assert both is not None and "(0.53 %) and 40 late (0.53 %), 1.07 % together, over 1 %" in both
    assert missed_period(summary | {"realtime": None}, 0.0004) is None  # lock-step: no period to miss
