"""A host and an emulator that disagree about time are refused before anything is enabled, with
one line naming both and the flag to change (``rig.host.time_mode``): a lock-step host against
``rig emulate`` in real time (its heartbeat comes without SYNC), and a real-time host against
``rig emulate --time lockstep`` (no heartbeat while no SYNC comes). Across processes, over
socketcand; the outcome does not depend on timing (a heartbeat of 100 ms against windows of a
quarter second and more)."""

from __future__ import annotations

import dataclasses
import pathlib

import pytest

from drivers.errors import ConfigError
from rig.config import BusConfig, RigConfig, load_config
from rig.emulator.spawn import spawn_emulator, stop_rig
from rig.host.session import Session

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def _config(out: pathlib.Path, time: str, port: int) -> RigConfig:
    """The example at 1 ms in ``time``, over socketcand to ``port``."""
    cfg = load_config(EXAMPLE)
    return dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, time=time, period=0.001, output=str(out)),  # type: ignore[arg-type]
        bus=BusConfig(interface="socketcand", channel="can0", port=port),
    )


@pytest.mark.parametrize(
    ("host", "emulator", "words"),
    [
        ("lockstep", (), ("keeps its own time", '[run] time = "lockstep"', "--time lockstep")),
        (
            "realtime",
            ("--time", "lockstep"),
            ("stands still without SYNC", '[run] time = "realtime"', "--time lockstep"),
        ),
    ],
    ids=["lockstep-host-realtime-emulator", "realtime-host-lockstep-emulator"],
)
def test_a_time_mode_mismatch_is_refused_before_the_enable(
    tmp_path: pathlib.Path, host: str, emulator: tuple[str, ...], words: tuple[str, ...]
) -> None:
    proc, port = spawn_emulator("--preset", "dc-servo", *emulator)
    try:
        cfg = _config(tmp_path, host, port)
        with Session(cfg, emulate=False, duration=0.1) as session:
            with pytest.raises(ConfigError) as refused:
                session.start()
            assert all(not getattr(a, "enabled", False) for a in session.axes)
    finally:
        stop_rig(proc, timeout=20)
    text = str(refused.value)
    assert "\n" not in text and "node 1" in text
    for word in words:
        assert word in text, text


@pytest.mark.parametrize("mode", ["lockstep", "realtime"])
def test_a_host_and_an_emulator_that_agree_are_not_refused(tmp_path: pathlib.Path, mode: str) -> None:
    proc, port = spawn_emulator("--preset", "dc-servo", "--time", mode)
    try:
        cfg = _config(tmp_path, mode, port)
        with Session(cfg, emulate=False, duration=0.05) as session:
            session.start()
            summary = session.run()
    finally:
        stop_rig(proc, timeout=20)
    assert summary["cycles"] > 0 and "time" not in str(summary["safe_stop_reason"])
