"""Table 1 of the DISMC paper through ``rig reproduce dismc``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rig.cli import main
from rig.config.params import parse_items, typed_values
from rig.papers.dismc import ALIASES, FIXED, DismcExample, run_dismc
from rig.report.step_response import overshoot, rise_time, settling_time

TABLE_1 = {"DISMC-LMI": (1.82, 2.88, -60.6, 135.8), "DISMC-LQR": (0.44, 0.72, -32.7, 175.1)}


@pytest.fixture(scope="module")
def runs() -> dict[str, object]:
    return {r.controller: r for r in run_dismc()}


@pytest.mark.parametrize("name", sorted(TABLE_1))
def test_table_1_rise_settling_and_u_max(runs: dict[str, object], name: str) -> None:
    rise, settle, u_min, u_max = TABLE_1[name]
    m = runs[name].metrics  # type: ignore[attr-defined]
    assert m["rise_time_s"] == pytest.approx(rise, abs=1e-9)
    assert m["settling_time_s"] == pytest.approx(settle, abs=1e-9)
    assert math.trunc(m["u_max"] * 10) / 10 == u_max
    assert m["u_max"] == runs[name].u[0]  # type: ignore[attr-defined]
    assert abs(m["u_min"] - u_min) < 0.35


def test_anti_windup_is_faster_and_gentler_in_the_initial_phase(runs: dict[str, object]) -> None:
    aw, lqr = runs["DISMC-AW-LQR"].metrics, runs["DISMC-LQR"].metrics  # type: ignore[attr-defined]
    assert aw["settling_time_s"] < lqr["settling_time_s"]
    assert aw["rise_time_s"] < lqr["rise_time_s"]
    head = slice(0, 50)
    assert np.max(np.abs(runs["DISMC-AW-LQR"].u[head])) < np.max(np.abs(runs["DISMC-LQR"].u[head]))  # type: ignore[attr-defined]


def test_integral_laws_have_zero_tracking_error_dsmc_does_not(runs: dict[str, object]) -> None:
    tail = slice(250, 300)
    for name in ("DISMC-LQR", "DISMC-AW-LQR"):
        assert np.max(np.abs(runs[name].e[tail])) < 1e-3  # type: ignore[attr-defined]
    assert np.max(np.abs(runs["DSMC"].e[tail])) > 1e-3  # type: ignore[attr-defined]


def test_json_contract(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reproduce", "dismc", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["controller"] for r in rows] == ["DSMC", "DISMC-LMI", "DISMC-LQR", "DISMC-AW-LQR"]
    for r in rows:
        assert set(r) == {"controller", "rise_time_s", "settling_time_s", "u_min", "u_max"}


def test_param_overrides_and_errors(capsys: pytest.CaptureFixture[str]) -> None:
    items = parse_items(["phi=0.8", "S=2,1", "Q=2,0;0,1", "H=solved", "disturbance_amplitude=0"], "--param")
    ex = DismcExample(**typed_values(DismcExample, items, "--param", aliases=ALIASES, fixed=FIXED, text=True))
    assert (ex.phi, ex.S, ex.Q, ex.H, ex.amplitude) == (
        0.8,
        (2.0, 1.0),
        ((2.0, 0.0), (0.0, 1.0)),
        "solved",
        0.0,
    )
    assert main(["reproduce", "dismc", "--param", "gamma=1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "gamma" in err[0]
    assert main(["reproduce", "dismc", "--param", "phi=1.5"]) == 2
    assert main(["reproduce", "dismc", "--param", "S=1,2,3"]) == 2
    assert "S needs 2 finite numbers" in capsys.readouterr().err
    assert main(["reproduce", "dismc", "--param", "H=guessed"]) == 2
    assert "one of printed, solved" in capsys.readouterr().err


def test_plot_is_written_with_titles_units_and_a_line_per_controller(tmp_path: object) -> None:
    from rig.papers.plots import plot_dismc

    out = tmp_path / "fig3.png"  # type: ignore[operator]
    assert main(["reproduce", "dismc", "--plot", str(out), "--json"]) == 0
    assert out.stat().st_size > 1000
    fig = plot_dismc(run_dismc(), str(out), dt=DismcExample().Ts)
    assert "Fig. 3" in fig._suptitle.get_text()
    assert len(fig.axes) == 3
    for ax in fig.axes:
        assert ax.get_title() and ax.get_ylabel().endswith("[-]")
        assert len(ax.get_lines()) == 4
        assert [t.get_text() for t in ax.get_legend().get_texts()] == [
            "DSMC",
            "DISMC-LMI",
            "DISMC-LQR",
            "DISMC-AW-LQR",
        ]
    assert fig.axes[-1].get_xlabel() == "time [s]"


def test_metric_definitions() -> None:
    e = [-1.0, -0.96, -0.5, -0.04, -0.02, -0.005, 0.0]
    assert rise_time(e, dt=0.1) == pytest.approx(0.1)  # p = 0.04 at k=1: 5 % at k=2, 95 % at k=3
    assert settling_time(e, dt=0.1, band=0.01) == pytest.approx(0.5)
    assert math.isnan(settling_time([1.0, 1.0], dt=0.1))
    assert overshoot([0.0, 1.2, 1.0], final=1.0) == pytest.approx(20.0)
