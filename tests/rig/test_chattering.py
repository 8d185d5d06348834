"""Chattering as engineers mean it: alternations beyond one count's effect, and the RMS increment."""

from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np
import pytest

from drivers.base import Feedback
from rig.config import load_config
from rig.host.loop_stats import ChatterCounter, RunMetrics
from rig.host.recorder import Recorder
from rig.host.session import Session, run_config
from rig.laws import make_law
from rig.report.metrics import chattering_amplitude, chattering_count, count_threshold

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"


def test_only_alternations_beyond_the_threshold_count() -> None:
    limit_cycle = [0.0, 0.01, 0.0, 0.01, 0.0, 0.01]  # a one-count wiggle of 10 mV
    relay = [10.0, -10.0, 10.0, -10.0, 10.0]
    assert chattering_count(limit_cycle) == 4  # exact measurements: every alternation
    assert chattering_count(limit_cycle, threshold=0.02) == 0
    assert chattering_count(relay, threshold=0.02) == 3
    assert chattering_count([0.0, 1.0, 2.0, 2.0, 3.0]) == 0  # monotone
    assert chattering_count([0.0, 1e-12, 0.0, 1e-12]) == 0  # rounding is never chattering
    assert chattering_amplitude(relay) == pytest.approx(20.0)
    assert chattering_amplitude(limit_cycle) == pytest.approx(0.01)
    assert math.isnan(chattering_amplitude([1.0]))


def test_the_threshold_is_one_count_through_the_law_s_gradient() -> None:
    assert count_threshold((55.6, 3.77), position_quantum=1e-3, velocity_quantum=2.5) == pytest.approx(
        0.0556 + 9.425
    )
    assert count_threshold((55.6, 3.77), position_quantum=0.0, velocity_quantum=0.0) == 0.0


@pytest.mark.parametrize("start", [0, 3])
def test_the_online_counter_equals_the_offline_metric(start: int) -> None:
    rng = np.random.default_rng(1)
    u = np.cumsum(rng.normal(size=400)) + 5.0 * np.sign(rng.normal(size=400))
    counter = ChatterCounter(2.0, start=start)
    for value in u:
        counter.add(float(value))
    assert counter.count == chattering_count(u[start:], threshold=2.0)
    assert counter.amplitude == pytest.approx(chattering_amplitude(u[start:]))


def test_the_servo_law_states_its_gradient_the_sign_law_its_continuous_part() -> None:
    base = {"a_m": 16.0, "b_m": 680.0}
    servo = make_law("position-servo", base, period=0.4e-3, reference=lambda t: (0.0, 0.0))
    sign = make_law("position-servo", {**base, "law": "sign"}, period=0.4e-3, reference=lambda t: (0.0, 0.0))
    (c1, c2), (k1, k2) = servo.servo.params.design.c_delta, servo.servo.params.design.c_delta_A_delta  # type: ignore[attr-defined]
    g = 1.0 / 0.4e-3 + 16.0
    assert servo.sensitivity() == pytest.approx((abs(k1 + g * c1), abs(k2 + g * c2)))
    assert sign.sensitivity() == pytest.approx((abs(k1), abs(k2)))
    # e_1 and e_2 as one measurement error: the command moves by the sensitivity
    e1, e2 = 1e-3, 2e-3
    u0 = servo.servo.step(0.0, 0.0)  # type: ignore[attr-defined]
    servo.servo.reset()  # type: ignore[attr-defined]
    u1 = servo.servo.step(e1, e2)  # type: ignore[attr-defined]
    assert abs(u1 - u0) == pytest.approx(servo.sensitivity()[0] * e1 + servo.sensitivity()[1] * e2, rel=1e-9)


def _servo_config(tmp_path: pathlib.Path, **controller: object):  # type: ignore[no-untyped-def]
    cfg = load_config(EXAMPLES / "dc_servo_position.toml")
    params = {**cfg.controller.params, **controller}
    return dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=2.0),
        controller=dataclasses.replace(cfg.controller, params=params),
    )


def test_rig_run_summary_over_the_bus_7_30_zero_sign_law_hundreds(tmp_path: pathlib.Path) -> None:
    """The 4096-count encoder: (7.30)'s one-count limit cycle is not chattering; the sign law's
    2 sigma switching is, about every other sample of the run's second half."""
    servo = run_config(_servo_config(tmp_path), emulate=True)
    sign = run_config(_servo_config(tmp_path, law="sign"), emulate=True)
    assert servo["chattering_count"] == 0
    assert 0.0 < servo["chattering_amplitude"] < 0.2  # V
    assert servo["chattering_threshold"] > 10.0  # V: a count over T through (c_2/T)
    assert sign["chattering_count"] > 300  # of 2500 cycles in the second half
    assert sign["chattering_amplitude"] > 10.0


def test_the_run_plot_is_titled_and_labelled_with_units(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(Recorder, "PLOT", True)
    cfg = _servo_config(tmp_path)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, duration=0.2))
    with Session(cfg, emulate=True) as session:
        session.start()
        recorder = session.recorder
        summary = session.run()
    assert (pathlib.Path(summary["run_dir"]) / "plot.png").stat().st_size > 1000
    fig = recorder.plot(recorder.array())
    top, bottom = fig.axes
    assert fig._suptitle.get_text().startswith("run dc-servo-position")
    assert top.get_ylabel() == "reference, measurement [rad]"
    assert bottom.get_ylabel() == "command [V]"
    assert bottom.get_xlabel() == "time [s]" and top.get_title() and bottom.get_title()
    assert [len(ax.get_lines()) for ax in fig.axes] == [2, 1]
    assert [t.get_text() for t in top.get_legend().get_texts()] == ["reference", "measurement"]


def test_a_count_is_not_measurable_where_one_count_covers_the_command_range(tmp_path: pathlib.Path) -> None:
    """examples/im_speed_idtsm.toml: one count of speed is worth about 22 N m through the IDTSM,
    the command's range is +-10 N m; no increment can exceed the threshold, so the count is None
    (JSON null), not a reassuring 0, and the summary says so; the amplitude is still measured."""
    from rig.report.summary import summary_lines

    cfg = load_config(EXAMPLES / "im_speed_idtsm.toml")
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=1.0))
    summary = run_config(cfg, emulate=True)
    limit = cfg.axes[0].limits.command
    assert summary["chattering_threshold"] >= 2.0 * limit
    assert summary["chattering_count"] is None
    assert summary["chattering_amplitude"] > 0.0
    text = "\n".join(summary_lines(summary))
    assert "not measurable" in text and "RMS increment" in text


def test_the_count_is_measured_below_the_command_range() -> None:
    metrics = RunMetrics(["m"], [{"velocity"}], [0], threshold=2.0, steady_from=0, command_range=4.0)
    for u in (0.0, 3.0, 0.0, 3.0):
        metrics.add(0.0, 0.0, [u], [Feedback(0.0, 0.0, 0.0, 0.0, None)])
    assert metrics.chattering_count == 2  # +3, -3, +3: two alternations
    metrics.command_range = 2.0
    assert metrics.chattering_count is None
