"""SIGTERM, SIGHUP and Ctrl-C (twice in quick succession too) are the one safe stop, across
real processes and sockets: ``rig emulate --device epos4`` and ``rig run`` (real time, CSV at
50 rad/s over socketcand) in processes of their own; the signal goes to ``rig run`` once its
drive turns. It exits 128 + the signal's number (docs/cli.md) printing no summary, only the line
naming its run directory, where summary.json and samples.mat are whole, and the drive is
disabled at rest. Nothing is decided by a sleep: each wait is for a condition.
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import threading

import canopen
import pytest
import scipy.io

from drivers.bus import open_bus
from plant_emulator.device_profile import load_profile, zoo
from rig.emulator.spawn import spawn_emulator, stop_rig
from rig.faults.wire_probe import wait_for
from tests.rig.test_host_death import run_config

pytestmark = pytest.mark.timing  #: real time across processes: wall-clock bound


def relaxed(out: pathlib.Path, port: int, eds: pathlib.Path) -> str:
    """test_host_death's run with a drive that watches the host with some slack: this test is
    about the signals (a loaded machine stalls the host's loop for more than 0.3 s)."""
    text = run_config(out, port, eds)
    return text.replace(
        'abort_connection = "quick-stop"', 'abort_connection = "quick-stop"\nhost_timeout = 1.0'
    )


@pytest.mark.parametrize(
    ("signals", "reason"),
    [
        ((signal.SIGTERM,), "SIGTERM (terminate)"),
        ((signal.SIGHUP,), "SIGHUP (hang-up)"),
        ((signal.SIGINT, signal.SIGINT), "Ctrl-C (SIGINT)"),
    ],
    ids=["sigterm", "sighup", "double-ctrl-c"],
)
def test_a_stop_signal_is_the_safe_stop(
    tmp_path: pathlib.Path, signals: tuple[signal.Signals, ...], reason: str
) -> None:
    eds = load_profile(zoo()["epos4"]).eds
    emulator, port = spawn_emulator("--device", "epos4")
    host: subprocess.Popen[str] | None = None
    try:
        bus = open_bus("socketcand", "can0", host="127.0.0.1", port=port)  # frames behind < ok > kept
        network = canopen.Network(bus)
        network.connect()
        tpdos = [0]
        lock = threading.Lock()

        def seen(cob: int, data: bytearray, ts: float) -> None:
            with lock:
                tpdos[0] += 1

        for cob in (0x181, 0x281):
            network.subscribe(cob, seen)
        config = tmp_path / "run.toml"
        config.write_text(relaxed(tmp_path, port, eds))
        host = subprocess.Popen(
            [sys.executable, "-m", "rig.cli", "run", "--config", str(config), "--json"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        wait_for(lambda: tpdos[0] > 200 or host.poll() is not None, 60.0, "the run's TPDOs")  # type: ignore[union-attr]
        assert host.poll() is None, host.communicate()[1][-3000:]
        for sig in signals:
            host.send_signal(sig)
        out, err = host.communicate(timeout=30)
        assert host.returncode == 128 + signals[0], err[-3000:]
        assert "Traceback" not in err, err[-3000:]
        assert out == "", out  # a run a signal stopped prints no summary: it is on disk
        (run_dir,) = (p.parent for p in tmp_path.glob("*/summary.json"))
        said = err.splitlines()[-1]
        assert said.startswith(f"rig run: stopped by {reason}; every drive stopped, at rest and"), said
        assert said.endswith(f"what was done is in {run_dir}"), said
        summary = json.loads((run_dir / "summary.json").read_text())
        assert summary["safe_stop_reason"] == reason and summary["stop_confirmed"] is True, summary
        mat = scipy.io.loadmat(run_dir / "samples.mat")
        assert mat["t"].size == summary["cycles"]
        assert not [p.name for p in run_dir.iterdir() if p.name.endswith(".tmp")]
        node = canopen.RemoteNode(1, str(eds))
        network.add_node(node)
        assert node.sdo[0x6041].raw & 0x4F == 0x40  # SWITCH ON DISABLED
        assert abs(node.sdo[0x606C].raw) <= 1  # rpm: at rest
        network.disconnect()
    finally:
        if host is not None and host.poll() is None:
            host.kill()
        _out, emulator_err = stop_rig(emulator, timeout=10)
    assert emulator.returncode == 0, emulator_err


def test_a_lost_bus_is_a_safe_stop_not_a_traceback(tmp_path: pathlib.Path) -> None:
    """The emulator (the far end of the socketcand link) is killed mid-run: ``rig run`` stops
    through the one stop with its summary and says the bus is lost; it cannot confirm the
    drive's stop over a dead link, so the exit code is 4 (the drive's own supervision takes
    over on real iron: test_host_death)."""
    eds = load_profile(zoo()["epos4"]).eds
    emulator, port = spawn_emulator("--device", "epos4")
    host: subprocess.Popen[str] | None = None
    try:
        config = tmp_path / "run.toml"
        config.write_text(relaxed(tmp_path, port, eds))
        host = subprocess.Popen(
            [sys.executable, "-m", "rig.cli", "run", "--config", str(config), "--json"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        running = host
        wait_for(lambda: any(tmp_path.glob("*/started.json")) or running.poll() is not None, 60.0, "the run")
        assert host.poll() is None, host.communicate()[1][-3000:]
        emulator.kill()
        emulator.communicate(timeout=10)
        out, err = host.communicate(timeout=60)
        assert host.returncode == 4, err[-3000:]
        assert "Traceback" not in err, err[-3000:]
        summary = json.loads(out)
        reason = summary["safe_stop_reason"]  # the send or the receive that failed first
        assert "Connection reset" in reason or "Broken pipe" in reason, summary
        assert "Traceback" not in reason
        assert summary["stop_confirmed"] is False
        run_dir = pathlib.Path(summary["run_dir"])
        assert json.loads((run_dir / "summary.json").read_text())["cycles"] == summary["cycles"]
    finally:
        if host is not None and host.poll() is None:
            host.kill()
        if emulator.poll() is None:
            emulator.kill()
        emulator.communicate(timeout=10)
