"""The vcan tier: ``rig emulate`` as its own process on vcan0, the host on python-can's socketcan."""

from __future__ import annotations

import socket
import subprocess
from collections.abc import Callable, Iterator

import pytest

from rig.config import BusConfig, RigConfig, replace_axis
from rig.emulator.spawn import spawn_rig, stop_rig
from rig.papers.demo import demo_config


def vcan_unavailable() -> str | None:
    """Why vcan0 cannot be used here, or None."""
    if not hasattr(socket, "AF_CAN"):
        return "this Python has no AF_CAN"
    try:
        with socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW) as s:
            s.bind(("vcan0",))
    except OSError as exc:
        return f"no SocketCAN vcan0 here ({exc.strerror}); see docs/testing.md, Testing with virtual CAN"
    return None


@pytest.fixture(autouse=True)
def _need_vcan(monkeypatch: pytest.MonkeyPatch) -> None:
    reason = vcan_unavailable()
    if reason:
        pytest.skip(reason)
    from drivers.canopen_axis import CanopenAxis

    monkeypatch.setattr(CanopenAxis, "SDO_TIMEOUT", 2.0)  # the VM's emulated CPU is slow, not the drive


@pytest.fixture
def start_emulator() -> Iterator[Callable[..., subprocess.Popen[str]]]:
    """Start ``rig emulate`` on vcan0 with the given arguments; stopped (SIGINT) after the test."""
    procs: list[subprocess.Popen[str]] = []

    def start(*args: str) -> subprocess.Popen[str]:
        proc, line = spawn_rig(
            "emulate", "--interface", "socketcan", "--channel", "vcan0", *args, stderr=True
        )
        procs.append(proc)
        assert "socketcan:vcan0" in line, line  # "rig emulate: ... on socketcan:vcan0; Ctrl-C stops"
        return proc

    yield start
    for proc in procs:
        _out, err = stop_rig(proc)
        if err.strip():  # what it said while it served, for a test that failed on its answers
            print(f"\nrig emulate's stderr (its last 4000 characters):\n{err[-4000:]}")
        assert proc.returncode == 0, err


def lockstep_servo(
    start_emulator: Callable[..., subprocess.Popen[str]], out: str
) -> tuple[RigConfig, RigConfig]:
    """The demo's servo: ``rig emulate`` of the dc-servo preset in lock-step on vcan0 with the
    demo's parameters; (the demo's in-process configuration, the host's over vcan0)."""
    import dataclasses

    cfg = demo_config(out)
    params = [arg for k, v in cfg.emulator.params.items() for arg in ("--param", f"{k}={v}")]
    start_emulator("--preset", "dc-servo", "--time", "lockstep", *params)
    wire = dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, period=0.4e-3),
        bus=BusConfig(interface="socketcan", channel="vcan0"),
    )
    # the VM is slow, not the drive
    return cfg, replace_axis(wire, "motor", enable_timeout=10.0, limits={"watchdog_periods": 10_000})
