"""``rig reproduce drives``: the drives paper's numbers, pure and over the emulated bus, and its plots.

One module-scoped reproduction with shortened horizons (the speed loop to 3.8 s, one period of
sin(5t) after 2.5 s; the servo to 2 s with the steady state from 1.8 s; the IM to 2.4 s, past the
load's first step) keeps the run short; the full one is ``rig reproduce drives``.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path
from typing import Any

import pytest

from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.presets import DcServoPreset
from rig.cli import main
from rig.laws import drives_paper as drives
from rig.papers.drives_study import DrivesStudy, drives_study, speed_error_theory
from rig.papers.plots import DRIVES_PLOTS, plot_drives

SHORT = DrivesStudy(speed_t_end=3.8, substeps=4, servo_t_end=2.0, servo_settle=1.8, im_t_end=2.4)
KEYS = ["design", "table_v", "speed_loop", "position_servo", "im_speed", "cascade"]


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], dict[str, Any]]:
    out = tmp_path_factory.mktemp("drives")
    doc, signals = drives_study(SHORT, str(out / "runs"))
    figures = plot_drives(signals, str(out / "plots"))
    return doc, figures


def _rows(doc: dict[str, Any], key: str, *, over_bus: bool | None = None) -> dict[str, dict[str, Any]]:
    return {r["name"]: r for r in doc[key] if over_bus is None or r["over_bus"] == over_bus}


def test_json_has_the_six_parts_and_named_rows(tmp_path: Path) -> None:
    out = io.StringIO()
    params = ["speed_t_end=0.2", "servo_t_end=0.4", "servo_settle=0.2", "im_t_end=0.3", "bus=false"]
    argv = ["reproduce", "drives", "--json", "--plot", str(tmp_path)]
    with contextlib.redirect_stdout(out):
        assert main(argv + [a for p in params for a in ("--param", p)]) == 0
    doc = json.loads(out.getvalue())
    assert list(doc) == KEYS
    assert isinstance(doc["design"], dict)
    for key in KEYS[1:]:
        assert doc[key] and all(isinstance(r, dict) and r["name"] for r in doc[key])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f for _, f in DRIVES_PLOTS)


@pytest.mark.parametrize("param", ["speed_t_end=0", "substeps=0", "load=nan", "horizon=3", "bus=maybe"])
def test_a_bad_param_is_one_line_and_exit_2(param: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reproduce", "drives", "--param", param]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and param.split("=", maxsplit=1)[0] in err


def test_design_7_31_gives_the_printed_digits(study: tuple[dict[str, Any], dict[str, Any]]) -> None:
    d = study[0]["design"]
    printed = d["printed"]
    assert [round(v, 4) for v in d["A_delta"][1]] == printed["A_delta"][1]
    assert round(d["A_delta"][0][1], 4) == printed["A_delta"][0][1]
    assert round(d["b_delta"][0], 5) == printed["b_delta"][0]
    assert round(d["b_delta"][1], 6) == printed["b_delta"][1]
    assert [round(v, 4) for v in d["c_delta"]] == printed["c_delta"]
    assert [round(v, 4) for v in d["c_delta_A_delta"]] == printed["c_delta_A_delta"]


def test_table_v_position_reproduced_speed_row_used_as_printed(
    study: tuple[dict[str, Any], dict[str, Any]],
) -> None:
    rows = _rows(study[0], "table_v")
    pos, cur, spd = rows["position"], rows["current"], rows["speed"]
    assert [round(v, 4) for v in pos["k_s_designed"]] == pos["k_s_printed"]
    assert [round(v, 4) for v in pos["c_s_designed"]] == pos["c_s_printed"]
    assert round(cur["k_s_designed"][0], 5) == -5.45217 and round(cur["c_s_designed"][0], 4) == 0.0236
    assert abs(spd["c_s_designed"][0] - spd["c_s_printed"][0]) > 4e-4  # does not follow from a_w, b_w
    assert spd["c_s_used"] == spd["c_s_printed"] and "as printed" in spd["decision"]
    assert spd["c_s_b_delta"] == pytest.approx(0.85, abs=0.005)


def test_speed_loop_amplitudes_are_the_delta_model_s(study: tuple[dict[str, Any], dict[str, Any]]) -> None:
    rows = study[0]["speed_loop"]
    assert [r["alpha"] for r in rows] == [None, 0.1, 0.5, 1.0, None]
    for r in rows:
        assert r["error_amplitude"] == pytest.approx(r["theory"], rel=1e-4), r["name"]
    amplitudes = [r["error_amplitude"] for r in rows]
    assert amplitudes == sorted(amplitudes, reverse=True)
    # T b_delta |f| for the law alone; (6.34) |z - 1| / alpha less with (6.30b)
    assert rows[0]["error_amplitude"] == pytest.approx(1.3557, abs=1e-4)
    assert rows[3]["error_amplitude"] == pytest.approx(0.002711, abs=1e-6)
    assert speed_error_theory("first", 0.1) == pytest.approx(10 * speed_error_theory("first", 1.0), rel=0.01)


def test_servo_7_30_does_not_chatter_the_sign_law_does(study: tuple[dict[str, Any], dict[str, Any]]) -> None:
    rows = study[0]["position_servo"]
    assert len(rows) == 6 and sum(r["over_bus"] for r in rows) == 3
    for r in rows:
        assert r["safe_stop_reason"] is None if r["over_bus"] else True
        if r["law"] == "7.30":
            assert r["chattering_count"] == 0 and r["sign_law_share"] == 0.0, r
            assert r["chattering_amplitude"] < 0.2, r  # V: a one-count limit cycle at most
        else:
            assert r["chattering_count"] > 100, r  # about one per sample in 0.2 s of 0.4 ms
            assert r["chattering_amplitude"] > 10.0, r  # 2 sigma = 20 V jumps
            assert r["sign_law_share"] == 1.0, r
    bus = {(r["law"], r["h"]): r for r in rows if r["over_bus"]}
    assert bus[("sign", None)]["chattering_threshold"] < 0.01  # the sign law's continuous part only
    # one count (1.5 mrad) and one increment/s of 0x606C (1.5 mrad/s) through (7.30)'s gradient
    assert 0.08 < bus[("7.30", 16.0)]["chattering_threshold"] < 0.1


def test_servo_integral_removes_the_load_error_h0_keeps_t_c2_f_over_c1(
    study: tuple[dict[str, Any], dict[str, Any]],
) -> None:
    """(7.30) with h = 0 leaves e = T c_2 f / c_1 with the load f = 1000 rad/s^2; over the bus the
    emulated motor's Coulomb friction, up to T_c/J = 32 rad/s^2 when it sticks at rest, holds
    part of the load or adds to it: e within T c_2 (f -+ T_c/J) / c_1."""
    c1, c2 = study[0]["design"]["c_delta"]
    theory = drives.T_SERVO * c2 * 1000.0 / c1  # (7.30) linear mode with h = 0: T c_2 f / c_1
    plant = DcServoPreset()
    stiction = plant.coulomb / DCMotorParams.from_am_bm(a_m=plant.a_m, b_m=plant.b_m, b=plant.friction).j
    band = drives.T_SERVO * c2 * stiction / c1
    for bus in (False, True):
        rows = {r["name"]: r for r in study[0]["position_servo"] if r["over_bus"] is bus}
        assert abs(rows["(7.30) h=16"]["steady_state_error"]) < 1e-3
        error = rows["(7.30) h=0"]["steady_state_error"]
        if bus:
            assert theory - band - 0.005 * theory < error < theory + band + 0.005 * theory
        else:
            assert error == pytest.approx(theory, rel=0.02)
    pure, wire = (
        _rows(study[0], "position_servo", over_bus=False),
        _rows(study[0], "position_servo", over_bus=True),
    )
    assert wire["(7.30) h=16"]["rms_error"] == pytest.approx(pure["(7.30) h=16"]["rms_error"], rel=0.1)


def test_im_idtsm_rejects_the_load_better_than_pi_pure_and_on_the_dyno(
    study: tuple[dict[str, Any], dict[str, Any]],
) -> None:
    for bus in (False, True):
        rows = _rows(study[0], "im_speed", over_bus=bus)
        idtsm, pi = rows["IDTSM (6.20)-(6.21), Table IV"], rows["PI, Table III"]
        assert idtsm["max_error"] < 0.3 * pi["max_error"], (idtsm, pi)
        if bus:
            assert idtsm["safe_stop_reason"] is None and pi["safe_stop_reason"] is None
    pure, wire = _rows(study[0], "im_speed", over_bus=False), _rows(study[0], "im_speed", over_bus=True)
    for name in pure:
        assert wire[name]["rms_error"] == pytest.approx(pure[name]["rms_error"], rel=0.25)


def test_cascade_tracks_pure_and_on_the_dyno(study: tuple[dict[str, Any], dict[str, Any]]) -> None:
    rows = study[0]["cascade"]
    assert [r["over_bus"] for r in rows] == [False, True]
    pure, wire = rows
    assert pure["max_error"] < 0.25 and wire["max_error"] < 0.35
    assert wire["rms_error"] == pytest.approx(pure["rms_error"], rel=0.5)
    assert wire["safe_stop_reason"] is None


def test_full_horizon_pure_runs_settle_under_the_load_without_chattering() -> None:
    """The whole 10 s of sections VII.C/D, pure simulation (cheap): under the constant 5 N m of
    2-4 s the integral laws leave no steady-state error and the command does not alternate."""
    doc, _ = drives_study(DrivesStudy(speed_t_end=0.1, servo_t_end=0.2, servo_settle=0.1, bus=False))
    for row in doc["im_speed"] + doc["cascade"]:
        assert row["chattering_count"] == 0, row
        assert abs(row["steady_state_error"]) < 1e-6, row
    rows = _rows(doc, "im_speed")
    assert rows["IDTSM (6.20)-(6.21), Table IV"]["max_error"] == pytest.approx(0.714, abs=0.01)
    assert rows["PI, Table III"]["max_error"] == pytest.approx(5.04, abs=0.05)


#: per experiment, the lines of each panel: runs (and a reference drawn once)
LINES = {
    "speed_loop": [5, 5, 5],
    "position_servo": [7, 6, 6],
    "im_speed": [5, 4, 5],
    "cascade": [3, 2, 4, 2],
}


@pytest.mark.parametrize("key", [k for k, _ in DRIVES_PLOTS])
def test_each_figure_is_titled_labelled_with_units_and_has_its_lines(
    study: tuple[dict[str, Any], dict[str, Any]], key: str
) -> None:
    fig = study[1][key]
    assert fig._suptitle is not None and fig._suptitle.get_text()
    axes = fig.axes
    assert [len(ax.get_lines()) for ax in axes] == LINES[key]
    for ax in axes:
        assert ax.get_title()
        assert ax.get_xlabel() == "time [s]"
        label = ax.get_ylabel()
        assert "[" in label and label.endswith("]"), label
        legend = ax.get_legend()
        assert legend is not None and len(legend.get_texts()) == len(ax.get_lines())
        assert all(math.isfinite(float(v)) for line in ax.get_lines() for v in line.get_ydata()[:1])
