"""A stop is confirmed only when every drive is disabled and every shaft then stayed at rest.

``rig.host.stopping``: after the drives' ramps and the disable, each axis with a shaft speed
must keep it within its at-rest window (``[axis.limits] rest_speed``) for its hold
(``rest_time``) of new samples in a row; otherwise the summary says which axis still turned,
at what speed, and the run exits 4. Lock-step on the emulated dc-servo drive.
"""

from __future__ import annotations

import dataclasses
import json
import math
import pathlib

import pytest

from rig.cli import main
from rig.config import load_config, replace_axis
from rig.host.session import Session
from rig.host.stopping import RestWatch
from rig.report.summary import summary_lines

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def test_the_hold_counts_new_samples_in_a_row_within_the_window() -> None:
    watch = RestWatch(0.05, 0.004, 1e-3)  # 4 samples of 1 ms
    assert watch.samples == 4
    assert not any(watch.see(s) for s in (0.0, 0.01, -0.04))
    assert not watch.see(None)  # no sample: counts neither way
    assert not watch.see(0.2)  # out of the window: the hold starts again
    assert [watch.see(s) for s in (0.0, 0.0, 0.0, 0.0)] == [False, False, False, True]
    assert not watch.see(math.nan) and watch.speed != watch.speed  # NaN is not at rest


def _run(tmp_path: pathlib.Path, load: str, **limits: float) -> dict:  # type: ignore[type-arg]
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=2.0),
        emulator=dataclasses.replace(cfg.emulator, params={**cfg.emulator.params, "load": load}),
    )
    cfg = replace_axis(cfg, "motor", limits={**limits, "speed": 1e4, "position_min": -1e6})
    with Session(cfg, emulate=True) as session:
        session.start()
        return session.run()


def test_a_load_that_ends_with_the_run_leaves_a_stop_confirmed(tmp_path: pathlib.Path) -> None:
    summary = _run(tmp_path, "pulse:0.0346:1.5:2")
    assert summary["stop_confirmed"] is True and summary["still_turning"] == {}


def test_an_active_load_that_turns_the_disabled_motor_is_no_confirmed_stop(tmp_path: pathlib.Path) -> None:
    """The load (1000 rad/s^2 over J, far above the friction's 32) stays on after the run: the
    drive's ramp ends (SWITCH ON DISABLED), the host disables, and the load turns the released
    shaft backwards. Before, the stop said "confirmed" and exit 0: the shaft span on unseen."""
    summary = _run(tmp_path, "step:0.0346:1.5")
    assert summary["stop_confirmed"] is False
    speed = summary["still_turning"]["motor"]
    assert speed < -5.0  # backwards, under the load
    assert json.loads(json.dumps(summary))["still_turning"] == {"motor": speed}
    text = "\n".join(summary_lines(summary))
    assert f"NO: still turning after the disable: motor at {speed:.4g} rad/s" in text


def test_a_fault_during_the_stop_is_no_confirmed_stop(
    tmp_path: pathlib.Path, caplog: pytest.LogCaptureFixture
) -> None:
    """The example's load cut at 2 s of its 1.5-3 s: after the disable it turns the shaft up to
    0x6080 (6000 rpm = 628.3 rad/s, 0.69 s later) and the drive trips 0x8400. Disabled, it has
    nothing to brake with: its fault reaction ends at once in FAULT and the shaft coasts on,
    turned faster by the load until it ends. Before, the stop said "confirmed" (the emulated
    drive braked the disabled shaft back to rest, the over-speed a warning in the log)."""
    summary = _run(tmp_path, "pulse:0.0346:1.5:3")
    assert summary["stop_confirmed"] is False
    speed = summary["still_turning"]["motor"]
    assert speed < -628.3  # past 0x6080, backwards under the load, coasting
    assert f"NO: still turning after the disable: motor at {speed:.4g} rad/s" in "\n".join(
        summary_lines(summary)
    )
    assert "motor: node 1: EMCY 0x8400 (velocity speed controller), error register 0x21 during the stop" in (
        caplog.text
    )


def test_a_window_and_hold_from_the_configuration(tmp_path: pathlib.Path) -> None:
    """A window wider than the turning speed passes for rest: the check is the axis's own."""
    summary = _run(tmp_path, "const:0.0012", rest_speed=1e3, rest_time=0.05)  # 0.1 mN m past T_c
    assert summary["stop_confirmed"] is True
    summary = _run(tmp_path, "const:0.0012", rest_time=0.05)
    assert summary["stop_confirmed"] is False and summary["still_turning"]["motor"] < 0.0


def test_rig_run_exits_4_and_says_so(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    text = text.replace('load = "pulse:0.0346:1.5:3"', 'load = "step:0.0346:1.5"').replace(
        "duration = 3.0", "duration = 1.6"
    )
    text = text.replace("position_min = -1.0", "position_min = -1e6").replace("speed = 300.0", "speed = 1e4")
    config = tmp_path / "run.toml"
    config.write_text(text)
    assert main(["run", "--config", str(config), "--emulate"]) == 4
    out = capsys.readouterr().out
    assert "stop confirmed  NO: still turning after the disable: motor at -" in out
