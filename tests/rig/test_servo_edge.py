"""The VII.B servo's stability edge, found by a study (issue 35 items 3 and 6): on a plant without
armature lag, load or friction, (7.30b)'s linear analysis, g(k+1) = (1 - k) g(k), puts it at twice
the design's b_m; a small sweep through it (k = 1.8, 1.9, 2.1, 2.2) sees the count and the
sign-law share change between 1.9 and 2.1 and nowhere else, and its plot draws the edge the
toolkit computes (``rig.sweep.edges``); on the preset plant the edge moves with its armature lag."""

from __future__ import annotations

import pathlib

import pytest

from drivers.files import read_toml
from rig.sweep.edges import b_m_edges, servo_edge
from rig.sweep.load import load_spec
from rig.sweep.point import point_config, read_base
from rig.sweep.points import Point

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
STUDY = EXAMPLES / "sweeps" / "servo_edge.toml"


def _small(tmp_path: pathlib.Path) -> pathlib.Path:
    """examples/sweeps/servo_edge.toml through the edge only, each point 0.5 s (a 1 rad move in
    0.2 s, its second half the steady state): 1250 cycles of 0.4 ms."""
    doc = read_toml(STUDY)
    fixed = "\n".join(f'"{k}" = {v!r}'.replace("'", '"') for k, v in doc["fixed"].items())
    text = f"""
[sweep]
name = "edge"
base = "{EXAMPLES / "dc_servo_position.toml"}"
output = "{tmp_path / "sweeps"}"
metrics = ["chattering_count", "sign_law_share", "chattering_threshold", "cycles"]

[parameters]
"emulator.params.b_m" = [{", ".join(str(680.0 * k) for k in (1.8, 1.9, 2.1, 2.2))}]

[fixed]
{fixed}
"run.duration" = 0.5
"reference.distance" = 1.0
"reference.duration" = 0.2
"""
    path = tmp_path / "edge.toml"
    path.write_text(text)
    return path


def test_a_small_sweep_through_the_lag_free_edge_changes_only_between_1_9_and_2_1(
    tmp_path: pathlib.Path, client: object
) -> None:
    from rig.sweep.engine import run_sweep
    from rig.sweep.plot import EDGE, figure

    spec = load_spec(_small(tmp_path))
    done = run_sweep(spec, client, {"kind": "test"})
    rows = {round(r["emulator.params.b_m"] / 680.0, 3): r for r in done.results.rows.values()}
    assert sorted(rows) == [1.8, 1.9, 2.1, 2.2]
    assert all(r["status"] == "completed" and r["cycles"] == 1250 for r in rows.values())
    steady = 625  # the second half's cycles: 624 increments
    for k in (1.8, 1.9):  # inside the edge: the deadbeat reaching settles, no alternation
        assert rows[k]["chattering_count"] == 0 and rows[k]["sign_law_share"] == 0.0, rows[k]
    for k in (2.1, 2.2):  # past it: (7.30) a sign-law relay every cycle
        assert rows[k]["chattering_count"] >= 0.99 * (steady - 2), rows[k]
        assert rows[k]["sign_law_share"] >= 0.99, rows[k]
    assert 0.08 < rows[1.9]["chattering_threshold"] < 0.1  # one count and one increment/s
    edges = b_m_edges(spec, list(rows.values()))
    assert list(edges.values()) == [pytest.approx(1.995 * 680.0, rel=1e-3)]
    lines = figure(spec, list(rows.values()), "chattering_count").axes[0].lines
    (edge,) = [line for line in lines if line.get_label().startswith(EDGE)]
    assert list(edge.get_xdata()) == [pytest.approx(1.995 * 680.0, rel=1e-3)] * 2


def test_the_preset_plant_s_armature_lag_and_a_period_s_delay_move_the_edge() -> None:
    """The example as shipped (0.1 ms armature lag, the command applied on receipt): 3.85 times
    the design's b_m at 0.4 ms; at 2 ms, 2.19 times; a command applied at the next SYNC makes the
    design itself unstable (the edge is the plant's own b_m)."""
    spec = load_spec(EXAMPLES / "sweeps" / "servo_b_m.toml")
    base = read_base(spec)

    def edge(**values: object) -> float | None:
        return servo_edge(point_config(spec, base, Point(0, {"emulator.params.b_m": 680.0, **values})))

    assert edge() == pytest.approx(3.848 * 680.0, rel=1e-3)
    assert edge(**{"emulator.params.period": 2e-3}) == pytest.approx(2.186 * 680.0, rel=1e-3)
    assert edge(**{"axis.motor.sync_rpdo": True}) == pytest.approx(680.0)
    assert edge(**{"controller.law": "sign"}) is None
