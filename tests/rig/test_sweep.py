"""``rig sweep``: the spec checked at load, the points, a point equal to a lone ``rig run``, the
table streamed in, resumed, and kept on Ctrl-C; a failing point is a row (issue 26).

The engine here is Dask's LocalCluster in this process (threads: quick to start); the test with
real scheduler and worker processes, one of them killed, is ``test_sweep_cluster.py``.
"""

from __future__ import annotations

import json
import math
import os
import pathlib

import pytest

from drivers.errors import ConfigError
from drivers.files import read_toml
from rig.cli import main
from rig.sweep.load import load_spec
from rig.sweep.point import job_of, read_base, run_point
from rig.sweep.points import make_points

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
SERVO = EXAMPLES / "dc_servo_position.toml"


def _spec(tmp_path: pathlib.Path, text: str, name: str = "spec.toml") -> pathlib.Path:
    path = tmp_path / name
    path.write_text(text.replace("SERVO", str(SERVO)).replace("OUT", str(tmp_path / "sweeps")))
    return path


DISMC = """
[sweep]
name = "aw"
scenario = "dismc"
output = "OUT"
metrics = ["rms_error", "u_max"]

[parameters]
controller = ["DISMC-LQR", "DISMC-AW-LQR"]
u_bound = { from = 30.0, to = 300.0, num = 3, scale = "log" }
"""


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ('[sweep]\nname = "x"\n[parameters]\na = [1]', "give base (a rig run configuration) or scenario"),
        (
            '[sweep]\nname = "x"\nscenario = "dismc"\nworkers = 2\n[parameters]\nu_bound = [1.0]',
            "unknown key 'workers'",
        ),
        (
            '[sweep]\nname = "x"\nscenario = "dismc"\n[parameters]\nu_bound = { from = 1.0, to = 2.0 }',
            "num >= 1",
        ),
        (
            '[sweep]\nname = "x"\nscenario = "dismc"\n[parameters]\n'
            'u_bound = { from = 0.0, to = 2.0, num = 3, scale = "log" }',
            "log scale needs",
        ),
        ('[sweep]\nname = "x"\nscenario = "dismc"\n[parameters]\nu_bound = [-1.0]', "u_bound = -1.0"),
        ('[sweep]\nname = "x"\nscenario = "dismc"\n[parameters]\nu_bnd = [1.0]', "unknown parameter 'u_bnd'"),
        (
            '[sweep]\nname = "x"\nscenario = "dismc"\nmetrics = ["rms"]\n[parameters]\nu_bound = [1.0]',
            "'rms' is not a figure",
        ),
        (
            '[sweep]\nname = "x"\nbase = "SERVO"\n[parameters]\n"controller.lamm" = [-10.0]',
            "controller.lamm = -10.0",
        ),
        (
            '[sweep]\nname = "x"\nbase = "SERVO"\n[parameters]\n"emulator.params.b_m" = [680.0, -1.0]',
            "emulator.params.b_m = -1.0",
        ),
        (
            '[sweep]\nname = "x"\nbase = "SERVO"\n[parameters]\n"axis.shaft.limits.command" = [1.0]',
            "the axes: 'motor'",
        ),
        (
            '[sweep]\nname = "x"\nbase = "SERVO"\nrepeats = 0\n[parameters]\n"run.duration" = [1.0]',
            "repeats = 0",
        ),
        (
            '[sweep]\nname = "x"\nscenario = "dismc"\nrepeats = 3\n[parameters]\nu_bound = [1.0]',
            "has no noise",
        ),
        (
            '[sweep]\nname = "x"\nscenario = "dq-current"\n[parameters]\nL_error = [0.0, -1.0]',
            "L_error must be > -1",
        ),
    ],
)
def test_a_bad_spec_is_one_error_naming_the_file_key_and_value(
    tmp_path: pathlib.Path, text: str, needle: str
) -> None:
    path = _spec(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        load_spec(path)
    assert str(path) in str(exc.value) and needle in str(exc.value), str(exc.value)


def test_grid_random_and_latin_hypercube_points(tmp_path: pathlib.Path) -> None:
    grid = load_spec(_spec(tmp_path, DISMC))
    points = make_points(grid)
    assert [(p.values["controller"], p.values["u_bound"]) for p in points[:3]] == [
        ("DISMC-LQR", 30.0),
        ("DISMC-LQR", 94.8683298051),
        ("DISMC-LQR", 300.0),
    ]
    assert len(points) == 6 and [p.index for p in points] == list(range(6))
    base = DISMC.replace("scenario = ", 'samples = 8\nseed = 4\nmethod = "lhs"\nscenario = ')
    base = base.replace("num = 3, ", "")
    lhs = make_points(load_spec(_spec(tmp_path, base, "lhs.toml")))
    u = sorted(p.values["u_bound"] for p in lhs)
    strata = [int(8 * math.log(x / 30.0) / math.log(10.0)) for x in u]
    assert strata == list(range(8))  # a Latin hypercube: each eighth of the log range once
    assert sorted(p.values["controller"] for p in lhs) == ["DISMC-AW-LQR"] * 4 + ["DISMC-LQR"] * 4
    assert make_points(load_spec(_spec(tmp_path, base, "lhs.toml"))) == lhs  # the seed repeats it
    rnd = make_points(load_spec(_spec(tmp_path, base.replace('"lhs"', '"random"'), "r.toml")))
    assert len(rnd) == 8 and all(30.0 <= p.values["u_bound"] <= 300.0 for p in rnd)
    repeats = SERVO_SPEC.replace("metrics = [", "repeats = 3\nnoise_seed = 7\nmetrics = [")
    rep = make_points(load_spec(_spec(tmp_path, repeats, "rep.toml")))
    assert [(p.index, p.seed, p.repeat) for p in rep[:4]] == [(0, 7, 0), (1, 8, 1), (2, 9, 2), (3, 7, 0)]


SERVO_SPEC = """
[sweep]
name = "servo"
base = "SERVO"
output = "OUT"
metrics = ["rms_error", "max_error", "chattering_count", "chattering_amplitude", "stop_confirmed", "cycles",
           "axes.motor.max_abs_velocity"]

[fixed]
"run.duration" = 0.1

[parameters]
"emulator.params.b_m" = [1360.0, 340.0]
"faults.frame_loss" = [0.0, 0.02]
"""


def test_a_point_equals_a_lone_rig_run_with_the_same_values(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The point (b_m = 340, 2 % frame loss, noise seed 5) run as a worker runs it, and the same
    values written into a configuration file run by ``rig run --emulate``: the same figures to
    1e-9 (and the lone run's summary, not a default, is what is compared)."""
    spec = load_spec(_spec(tmp_path, SERVO_SPEC.replace("metrics = [", "noise_seed = 5\nmetrics = [")))
    (point,) = [
        p for p in make_points(spec) if p.values == {"emulator.params.b_m": 340.0, "faults.frame_loss": 0.02}
    ]
    row = run_point(job_of(spec, read_base(spec), point))
    assert row["error"] is None and row["seed"] == 5 and row["elapsed_s"] >= row["run_s"] > 0.0
    doc = read_toml(SERVO)
    doc["run"].update(duration=0.1, output=str(tmp_path / "lone"))
    doc["emulator"]["params"]["b_m"] = 340.0
    doc["faults"] = {"frame_loss": 0.02, "seed": 5}
    lone = tmp_path / "lone.toml"
    lone.write_text(_toml(doc))
    assert main(["run", "--config", str(lone), "--emulate", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["rms_error"] > 1e-4 and summary["chattering_count"] is not None
    for metric in spec.metrics:
        value: object = summary
        for key in metric.split("."):
            value = value[key]  # type: ignore[index]
        assert row[metric] == pytest.approx(value, rel=1e-9, abs=1e-12), metric
    other = run_point(job_of(spec, read_base(spec), make_points(spec)[0]))
    assert other["rms_error"] != pytest.approx(row["rms_error"], rel=1e-3)  # the values reach the run


def _toml(doc: dict[str, object], prefix: str = "") -> str:
    """A small TOML writer for the test's document (tables, arrays of tables, scalars)."""
    lines, tables = [], []
    for key, value in doc.items():
        if isinstance(value, dict):
            tables.append((f"{prefix}{key}", value, False))
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            tables.extend((f"{prefix}{key}", v, True) for v in value)
        else:
            lines.append(f"{key} = {json.dumps(value)}")
    out = "\n".join(lines) + "\n"
    for name, table, array in tables:
        out += f"\n[[{name}]]\n" if array else f"\n[{name}]\n"
        out += _toml(table, f"{name}.")
    return out


def test_every_point_streams_into_the_table_once_and_resume_skips_them(
    tmp_path: pathlib.Path, client: object
) -> None:
    import pyarrow.parquet as pq

    from rig.sweep.engine import run_sweep

    spec = load_spec(_spec(tmp_path, DISMC))
    seen: list[int] = []
    done = run_sweep(spec, client, {"kind": "test"}, on_row=lambda r, total: seen.append(r.done), every=0.0)
    assert not done.interrupted and seen == [1, 2, 3, 4, 5, 6]
    table = pq.read_table(spec.directory / "results.parquet").to_pylist()
    assert sorted(r["point"] for r in table) == list(range(6))
    assert {"controller", "u_bound", "seed", "rms_error", "u_max", "error", "elapsed_s", "worker"} <= set(
        table[0]
    )
    by = {(r["controller"], r["u_bound"]): r for r in table}
    assert by[("DISMC-AW-LQR", 30.0)]["rms_error"] < by[("DISMC-LQR", 30.0)]["rms_error"] / 100  # windup
    record = json.loads((spec.directory / "sweep.json").read_text())
    assert record["counts"] == {"points": 6, "resumed": 0, "done": 6, "failed": 0}
    assert record["status"] == "complete" and record["spec"]["scenario"] == "dismc"
    relative = load_spec(os.path.relpath(spec.source))  # the same spec, named from here
    again = run_sweep(relative, client, {"kind": "test"}, resume=True)
    assert again.resumed == 6 and again.results.done == 6
    with pytest.raises(ConfigError, match="--resume to go on"):
        run_sweep(spec, client, {"kind": "test"})
    changed = load_spec(_spec(tmp_path, DISMC.replace("num = 3", "num = 4")))
    with pytest.raises(ConfigError, match="changed: parameters"):
        run_sweep(changed, client, {"kind": "test"}, resume=True)


def test_ctrl_c_keeps_what_finished_and_resume_runs_the_rest(tmp_path: pathlib.Path, client: object) -> None:
    import pyarrow.parquet as pq

    from rig.sweep.engine import run_sweep

    text = DISMC.replace('scenario = "dismc"', 'scenario = "dq-current"').replace(
        'metrics = ["rms_error", "u_max"]', ""
    )
    text = text.replace('controller = ["DISMC-LQR", "DISMC-AW-LQR"]', 'controller = ["proposed", "pi"]')
    text = text.replace(
        'u_bound = { from = 30.0, to = 300.0, num = 3, scale = "log" }', "L_error = [-0.5, 0.0, 0.5]"
    )
    spec = load_spec(_spec(tmp_path, text))

    def stop(results: object, total: int) -> None:
        if results.done == 3:  # type: ignore[attr-defined]
            raise KeyboardInterrupt

    done = run_sweep(spec, client, {"kind": "test"}, on_row=stop, every=60.0)
    assert done.interrupted and done.results.done == 3
    assert json.loads((spec.directory / "sweep.json").read_text())["status"] == "interrupted"
    assert len(pq.read_table(spec.directory / "results.parquet")) == 3  # written at the interrupt
    rest = run_sweep(spec, client, {"kind": "test"}, resume=True)
    rows = {(r["controller"], r["L_error"]): r for r in rest.results.rows.values()}
    assert len(rows) == 6 and rest.results.failed == 0 and rest.resumed == 3
    assert rows[("pi", 0.5)]["peak_id"] > rows[("proposed", 0.5)]["peak_id"]


def test_a_failing_point_is_a_row_never_the_end_of_the_sweep(tmp_path: pathlib.Path, client: object) -> None:
    """The law raises at 0.05 s on one point: a safe stop, its row says so, and its performance
    figures are NaN, never 0 (a filter on chattering-free rows kept it: issue 35); the others ran."""
    from rig.sweep.engine import run_sweep

    text = SERVO_SPEC.replace('"faults.frame_loss" = [0.0, 0.02]', '"faults.law_error_at" = [0.05, 1.0]')
    text = text.replace('"emulator.params.b_m" = [1360.0, 340.0]', '"emulator.params.b_m" = [680.0]')
    spec = load_spec(_spec(tmp_path, text))
    done = run_sweep(spec, client, {"kind": "test"})
    rows = {r["faults.law_error_at"]: r for r in done.results.rows.values()}
    assert done.results.failed == 1 and rows[1.0]["error"] is None
    assert rows[0.05]["error"].startswith("safe stop: exception in the control loop")
    assert rows[0.05]["stop_reason"] and rows[0.05]["stop_confirmed"] is True
    assert rows[0.05]["status"] == "stopped" and rows[1.0]["status"] == "completed"
    for metric in ("rms_error", "max_error", "chattering_count", "chattering_amplitude"):
        assert math.isnan(rows[0.05][metric]) and math.isfinite(rows[1.0][metric]), metric
    assert rows[0.05]["cycles"] > 0  # not a performance figure: how far it came


def test_a_point_past_its_time_out_stops_safely_and_is_a_row(tmp_path: pathlib.Path) -> None:
    spec = load_spec(_spec(tmp_path, SERVO_SPEC.replace("metrics = [", "timeout = 1e-9\nmetrics = [")))
    row = run_point(job_of(spec, read_base(spec), make_points(spec)[0]))
    assert row["error"].startswith("safe stop: time-out") and row["stop_confirmed"] is True
    assert 0 < row["cycles"] < 250  # stopped at the first 1 % of its cycles
    assert row["status"] == "stopped" and math.isnan(row["rms_error"]) and math.isnan(row["chattering_count"])


def test_the_plots_draw_each_metric_with_units(tmp_path: pathlib.Path, client: object) -> None:
    from rig.sweep.engine import run_sweep
    from rig.sweep.plot import plot_results

    spec = load_spec(_spec(tmp_path, DISMC))
    done = run_sweep(spec, client, {"kind": "test"})
    paths = plot_results(spec, list(done.results.rows.values()), str(tmp_path / "plots"))
    assert [p.name for p in paths] == ["aw-rms_error.png", "aw-u_max.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)


def test_a_point_not_kept_syncs_nothing_and_a_kept_one_is_a_run_directory(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A point's run directory is temporary (no plot, no fsync: nothing of it is kept) unless
    keep_runs; the recorder's class switches are left alone (a worker may run points in threads)."""
    from rig.host.recorder import Recorder

    syncs: list[int] = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (syncs.append(fd), real(fd))[1])
    spec = load_spec(_spec(tmp_path, SERVO_SPEC))
    assert run_point(job_of(spec, read_base(spec), make_points(spec)[0]))["error"] is None
    assert len(syncs) <= 1  # config.json, written as the session is built
    assert Recorder.DURABLE is True and Recorder.PLOT is False  # the class's: conftest's PLOT
    assert not (spec.directory / "runs").exists()
    kept = load_spec(_spec(tmp_path, SERVO_SPEC.replace("metrics = [", "keep_runs = true\nmetrics = [")))
    assert run_point(job_of(kept, read_base(kept), make_points(kept)[0]))["error"] is None
    (run,) = (kept.directory / "runs").iterdir()
    assert run.name.startswith("point-00000-") and (run / "summary.json").is_file() and len(syncs) > 3


def test_a_base_by_relative_path_is_found_by_a_worker_started_in_another_folder(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The spec named by a relative path, its base beside it naming its design file by a relative
    path: a worker whose working folder is elsewhere (``dask worker`` started in another folder)
    runs the point (failed before: 'rel/design.json: no such identification or design')."""
    study = tmp_path / "rel"
    study.mkdir()
    args = [
        "design",
        "dtsm",
        "--a-m",
        "16",
        "--b-m",
        "680",
        "--period",
        "4e-4",
        "--lam",
        "-15",
        "--error-space",
    ]
    assert main([*args, "--json"]) == 0
    (study / "design.json").write_text(capsys.readouterr().out)
    base = SERVO.read_text().replace("a_m = 16.0\nb_m = 680.0\nlam = -15.0\n", 'design = "design.json"\n')
    assert 'design = "design.json"' in base
    (study / "base.toml").write_text(base)
    text = SERVO_SPEC.replace('base = "SERVO"', 'base = "base.toml"').replace("SERVO", str(SERVO))
    (study / "spec.toml").write_text(text.replace("OUT", str(tmp_path / "sweeps")))
    monkeypatch.chdir(tmp_path)
    spec = load_spec("rel/spec.toml")
    job = job_of(spec, read_base(spec), make_points(spec)[0])
    elsewhere = tmp_path / "worker"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    row = run_point(job)
    assert row["error"] is None and row["cycles"] == 250.0, row["error"]


@pytest.mark.parametrize("server", ["silent", "http", "none", "malformed"])
def test_a_scheduler_address_where_no_dask_scheduler_answers_is_one_line(
    tmp_path: pathlib.Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    server: str,
) -> None:
    """--scheduler at a port that accepts and says nothing (Dask's connect timeout does not cover
    its handshake: the Client waited for ever), at an HTTP server (its bytes read as a frame
    length: MemoryError), at a closed port, or a malformed address (ValueError): one line,
    exit code 2, within the connection's and the handshake's bounds."""
    import socket
    import threading

    from rig.sweep import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 1.0)
    monkeypatch.setattr(cluster, "HANDSHAKE", 1.0)
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    if server == "none":
        listener.close()
    else:
        listener.listen(4)  # the kernel completes each connection; "silent" never accepts
    accepted: list[socket.socket] = []
    if server == "http":

        def answer() -> None:
            conn, _ = listener.accept()
            accepted.append(conn)
            conn.sendall(b"HTTP/1.0 426 Upgrade Required\r\nserver: keryx\r\n\r\n")

        thread = threading.Thread(target=answer, daemon=True)
        thread.start()
    address = "nonsense" if server == "malformed" else f"tcp://127.0.0.1:{port}"
    try:
        assert main(["sweep", str(_spec(tmp_path, DISMC)), "--scheduler", address]) == 2
    finally:
        if server == "http":
            thread.join()
        for conn in accepted:
            conn.close()
        listener.close()
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and f"--scheduler {address}: " in err, err
    assert "'dask scheduler'" in err and not (tmp_path / "sweeps").exists()


def test_the_plots_leave_failed_points_out_and_take_true_false_and_empty_metrics(
    tmp_path: pathlib.Path,
) -> None:
    """Rows of a rig run study as a sweep writes them: a safe-stopped point (its figures those of
    a run cut short) is not in the line and is a red x; stop_confirmed, a true/false metric of the
    defaults, is 1/0 (was an empty plot; on a sampled study a ValueError of matplotlib's log axis,
    'Data cannot be log-scaled', that ended rig sweep --plot after the points); a metric without a
    single number draws its points all the same. A list of values over a decade is a log axis."""
    from rig.sweep.plot import figure, plot_results

    text = SERVO_SPEC.replace('"faults.frame_loss" = [0.0, 0.02]', "")
    text = text.replace(
        '"emulator.params.b_m" = [1360.0, 340.0]', '"emulator.params.b_m" = [170.0, 680.0, 2720.0]'
    )
    spec = load_spec(_spec(tmp_path, text))
    rows = [
        {
            "point": i,
            "emulator.params.b_m": b,
            "rms_error": e,
            "stop_confirmed": True,
            "chattering_count": None,
        }
        | {"error": "safe stop: motor, node 1: no TPDO for 3 periods" if i == 1 else None}
        for i, (b, e) in enumerate(((170.0, 0.002), (680.0, 0.5), (2720.0, 0.07)))
    ]
    ax = figure(spec, rows, "rms_error").axes[0]
    (line,), failed = [x for x in ax.lines if x.get_label() == "mean"], ax.lines[-1]
    assert list(line.get_xdata()) == [170.0, 2720.0] and list(line.get_ydata()) == [0.002, 0.07]
    assert list(failed.get_xdata()) == [680.0] and failed.get_marker() == "x"
    assert ax.get_xscale() == "log"
    confirmed = figure(spec, rows, "stop_confirmed").axes[0]
    (mean,) = [x for x in confirmed.lines if x.get_label() == "mean"]
    assert list(mean.get_ydata()) == [1.0, 1.0] and "1 = true" in confirmed.get_ylabel()
    sampled = SERVO_SPEC.replace("metrics = [", 'method = "random"\nsamples = 4\nseed = 2\nmetrics = [')
    sampled = sampled.replace("[1360.0, 340.0]", "{ from = 340.0, to = 1360.0, scale = 'log' }")
    sampled = sampled.replace('"faults.frame_loss" = [0.0, 0.02]', "")
    sampled += '"emulator.params.counts_per_rev" = { from = 512, to = 8192, integer = true, scale = "log" }\n'
    spec = load_spec(_spec(tmp_path, sampled, "sampled.toml"))
    rows = [
        {"point": p.index, **p.values, "stop_confirmed": True, "chattering_count": None, "rms_error": 0.01}
        | {"error": None if p.index else "safe stop: time-out"}
        for p in make_points(spec)
    ]
    paths = plot_results(spec, rows, str(tmp_path / "plots"))
    assert len(paths) == len(spec.metrics) and all(p.stat().st_size > 10_000 for p in paths)


def test_a_point_that_raises_has_status_error_and_nan_figures_never_0(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A scenario that raises: its row's status is "error" and every metric NaN (was None, which
    a table reads as missing, and a rig run's stopped point had its 0 chattering: issue 35)."""
    import dataclasses

    from rig.sweep import scenarios

    def boom(point: object) -> dict[str, object]:
        raise RuntimeError("diverged")

    monkeypatch.setitem(
        scenarios.SCENARIOS, "dismc", dataclasses.replace(scenarios.SCENARIOS["dismc"], run=boom)
    )
    spec = load_spec(_spec(tmp_path, DISMC))
    row = run_point(job_of(spec, read_base(spec), make_points(spec)[0]))
    assert row["status"] == "error" and row["error"] == "RuntimeError: diverged"
    assert all(math.isnan(row[m]) for m in spec.metrics)


def test_failed_points_are_marked_at_the_foot_of_a_log_axis(tmp_path: pathlib.Path) -> None:
    """A stopped point's figures are NaN: its red x stands at the foot of the axes (their x in
    data, their y in axes units), seen on a logarithmic metric axis too (at 0 it was not)."""
    from rig.sweep.plot import figure

    spec = load_spec(
        _spec(
            tmp_path,
            SERVO_SPEC.replace('"faults.frame_loss" = [0.0, 0.02]', "").replace(
                "[1360.0, 340.0]", "[170.0, 680.0, 2720.0]"
            ),
        )
    )
    rows = [
        {"point": 0, "emulator.params.b_m": 170.0, "status": "completed", "error": None, "rms_error": 0.001},
        {
            "point": 1,
            "emulator.params.b_m": 680.0,
            "status": "stopped",
            "error": "safe stop: x",
            "rms_error": math.nan,
        },
        {"point": 2, "emulator.params.b_m": 2720.0, "status": "completed", "error": None, "rms_error": 0.5},
    ]
    ax = figure(spec, rows, "rms_error").axes[0]
    assert ax.get_yscale() == "log"
    failed = ax.lines[-1]
    assert list(failed.get_xdata()) == [680.0] and list(failed.get_ydata()) == [0.03]
    assert failed.get_transform() == ax.get_xaxis_transform()
    assert "failed" in ax.get_legend().get_texts()[-1].get_text()
