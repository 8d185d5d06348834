"""The view's disk side (issue 38): the runs under a folder newest first, a run's description, its
samples decimated to their envelope, its CAN trace filtered by COB-ID, a study's table, and the
page's API over them through the app (Starlette's TestClient; nothing listens)."""

from __future__ import annotations

import json
import pathlib
import time
from typing import Any

import numpy as np
import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from starlette.testclient import TestClient

from rig.config import load_config
from rig.host.session import run_config
from rig.view.app import make_app
from rig.view.meta import read_meta
from rig.view.store import Store, ViewError, cob_filter, frame_name

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
DYNO = EXAMPLES / "dyno_speed_load.toml"
SERVO = EXAMPLES / "dc_servo_position.toml"


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """Two runs (the servo, then the dyno) and a study with a failed point."""
    import dataclasses

    out = tmp_path_factory.mktemp("view") / "runs"
    for path, seconds in ((SERVO, 0.3), (DYNO, 0.2)):
        if out.exists():  # the dyno's started.json says a later wall time than the servo's
            servo = json.loads(next(out.glob("*/started.json")).read_text())["wall_time"]
            while time.time() <= servo:  # a condition, not a pause: a run takes far longer
                time.sleep(0.001)
        cfg = load_config(path)
        cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(out)))
        run_config(cfg, emulate=True, duration=seconds)
    study = out / "servo-b_m"
    study.mkdir()
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = [
        {"point": 0, "emulator.params.b_m": 170.0, "rms_error": 0.3, "stop_reason": None, "error": None},
        {"point": 1, "emulator.params.b_m": 680.0, "rms_error": 0.1, "stop_reason": None, "error": None},
        {
            "point": 2,
            "emulator.params.b_m": 2720.0,
            "rms_error": float("nan"),
            "stop_reason": None,
            "error": "boom",
        },
    ]
    pq.write_table(pa.Table.from_pylist(rows), study / "results.parquet")
    spec = {"parameters": [{"name": "emulator.params.b_m", "unit": "rad/(V s^2)", "scale": "log"}]}
    spec["metrics"] = ["rms_error"]
    (study / "sweep.json").write_text(json.dumps({"spec": spec, "status": "complete", "base": {}}))
    return out


def _client(folder: pathlib.Path) -> TestClient:
    return TestClient(make_app(Store([folder]), None), base_url="http://127.0.0.1:8050")


def test_runs_newest_first_with_their_figures(folder: pathlib.Path) -> None:
    runs = Store([folder]).runs()
    assert [r["name"].rsplit("-", 2)[0] for r in runs] == ["dyno-speed-load", "dc-servo-position"]
    assert runs[0]["cycles"] == 500 and runs[1]["cycles"] == 750  # the dyno at 0.4 ms, the servo at 0.4 ms
    assert all(r["trace"] and not r["in_progress"] and r["stop_reason"] is None for r in runs)


def test_a_run_s_charts_are_its_axes_with_units(folder: pathlib.Path) -> None:
    dyno = Store([folder]).runs()[0]["name"]
    meta = read_meta(folder / dyno)
    charts = {c["axis"]: c for c in meta["charts"]}
    assert list(charts) == ["motor", "encoder", "load", "loop"]
    assert charts["encoder"]["shown"] == ["reference", "measurement"]  # the law reads the encoder
    assert charts["motor"]["shown"] == ["motor.velocity", "motor.command"]
    units = {c["name"]: c["unit"] for c in meta["columns"]}
    assert units["motor.command"] == "V" and units["load.command"] == "N m" and units["t"] == "s"


def test_samples_keep_their_envelope(folder: pathlib.Path) -> None:
    store = Store([folder])
    servo = store.runs()[1]["name"]
    data = np.loadtxt(folder / servo / "samples.csv", delimiter=",", skiprows=1)
    columns, rows = store.samples("0", servo, "100")
    got = np.array(rows, dtype=float)
    assert len(got) <= 100 and got.shape[1] == len(columns) == data.shape[1]
    cmd = columns.index("command")  # a chattering command keeps its band, not one side of it
    assert np.nanmax(got[:, cmd]) == data[:, cmd].max() and np.nanmin(got[:, cmd]) == data[:, cmd].min()
    _, all_rows = store.samples("0", servo, None)
    np.testing.assert_array_equal(np.array(all_rows, dtype=float), data)  # 750 rows < 4000: all of them


def test_the_trace_filtered_by_cob_id(folder: pathlib.Path) -> None:
    store = Store([folder])
    servo = store.runs()[1]["name"]
    every = store.trace("0", servo, None, None, "1000")
    ids = {x["cob_id"]: x for x in every["ids"]}
    assert 0x080 in ids and 0x181 in ids and 0x201 in ids
    tpdo = store.trace("0", servo, "181", None, "5")
    assert tpdo["matched"] == ids[0x181]["frames"] and len(tpdo["frames"]) == 5
    assert {f["cob_id"] for f in tpdo["frames"]} == {0x181} and tpdo["frames"][0]["name"] == "TPDO1 node 1"
    page = store.trace("0", servo, "180-1ff, 0x80", "10", "3")
    assert page["offset"] == 10 and len(page["frames"]) == 3
    assert page["matched"] == sum(x["frames"] for k, x in ids.items() if 0x180 <= k <= 0x1FF or k == 0x80)


def test_cob_filters_and_names() -> None:
    assert cob_filter("181, 0x201 180-1FF") == [(0x181, 0x181), (0x201, 0x201), (0x180, 0x1FF)]
    assert frame_name(0x080) == "SYNC" and frame_name(0x701) == "heartbeat node 1" and frame_name(0x7FF) == ""
    for bad in ("zz", "181;rm", "1-2-3", ",".join(["1"] * 65)):
        with pytest.raises(ViewError) as info:
            cob_filter(bad)
        assert info.value.status == 400


def test_a_study_s_rows_and_its_failed_point(folder: pathlib.Path) -> None:
    doc = Store([folder]).study("0", "servo-b_m")
    assert doc["parameters"] == ["emulator.params.b_m"] and doc["metrics"] == ["rms_error"]
    assert [r["error"] for r in doc["rows"]] == [None, None, "boom"]
    assert doc["rows"][2]["rms_error"] is None  # NaN is JSON's null
    assert doc["units"] == {"emulator.params.b_m": "rad/(V s^2)"}


def test_the_api_over_http(folder: pathlib.Path) -> None:
    client = _client(folder)
    page = client.get("/")
    assert page.status_code == 200 and "uPlot.iife.min.js" in page.text
    assert client.get("/static/third_party/uplot/uPlot.iife.min.js").status_code == 200
    runs = client.get("/api/runs").json()
    run: dict[str, Any] = client.get(f"/api/runs/0/{runs[0]['name']}").json()
    assert run["summary"]["cycles"] == 500 and run["config"]["controller"]["kind"] == "idtsm-speed"
    samples = client.get(f"/api/runs/0/{runs[0]['name']}/samples?points=50").json()
    assert len(samples["rows"]) <= 50 and samples["columns"][0] == "t"
    assert client.get("/api/studies").json()[0]["name"] == "servo-b_m"
    bad = client.get(f"/api/runs/0/{runs[0]['name']}/samples?points=many")
    assert bad.status_code == 400 and "points" in bad.json()["error"]
    assert client.get(f"/api/runs/0/{runs[0]['name']}/trace?cob=xyz").status_code == 400
    assert client.get("/api/info").json() == {"read_only": True, "live": False}


def test_every_asset_is_in_the_package() -> None:
    """No CDN: the page's src, href, import and url() name only the package's own files."""
    from rig.view.app import STATIC

    ours = [p for p in STATIC.iterdir() if p.suffix in (".html", ".js", ".css")]
    assert {p.name for p in ours} >= {
        "index.html",
        "view.js",
        "live.js",
        "runs.js",
        "studies.js",
        "charts.js",
    }
    import re

    for path in ours:
        text = path.read_text()
        links = re.findall(r"""(?:src|href)="([^"]*)"|from "([^"]*)"|url\(([^)]*)\)""", text)
        for link in (x for group in links for x in group if x):
            assert link.startswith(("/static/", "./", "data:", "#")) or link == "/", (path.name, link)
    for name in ("uPlot.iife.min.js", "uPlot.min.css", "LICENSE"):
        assert (STATIC / "third_party" / "uplot" / name).is_file()


def test_the_page_s_scripts_parse(tmp_path: pathlib.Path) -> None:
    """Each of the page's modules is JavaScript that Node.js parses (the browser tier runs them)."""
    import shutil
    import subprocess

    from rig.view.app import STATIC

    node = shutil.which("node")
    if node is None:
        pytest.skip("no node: the browser tier checks the scripts")
    for script in STATIC.glob("*.js"):
        module = tmp_path / (script.stem + ".mjs")
        module.write_text(script.read_text())
        done = subprocess.run([node, "--check", str(module)], check=False, capture_output=True, text=True)
        assert done.returncode == 0, (script.name, done.stderr[-500:])
