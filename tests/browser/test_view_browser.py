"""The view in a real browser (issue 38 item 4): Debian's Chromium driven by Playwright's Python
package (``executable_path``: the system's browser; Playwright's own browser download is never
used). The live scope advances during an emulated run and shows its summary at the end; a past
run's plot shows its samples; two runs overlay; the trace filters by COB-ID; a study's table sorts
with its failed point marked; an identification's Bode plot draws; and no request leaves
127.0.0.1 (the page works with no network). Screenshots go to ``ci-artifacts/browser/``.

Run with ``python -m pytest -m browser -n 0`` (.ci/run does, after ``apt-get install chromium``
and ``pip install -e '.[view,browser]'``)."""

from __future__ import annotations

import dataclasses
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import textwrap
import urllib.parse
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

pytestmark = [pytest.mark.browser, pytest.mark.timeout(900)]  # the fixtures run rig identify and rig sweep

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
ARTIFACTS = pathlib.Path(os.environ.get("RIG_ARTIFACTS", ROOT / "ci-artifacts")) / "browser"
CHROMIUM = os.environ.get("RIG_CHROMIUM", "/usr/bin/chromium")
#: the flags this machine's Chromium needs (no sandbox as root; no background connections)
FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
WAIT = 60_000  #: [ms] a page's state awaited at most (a loaded machine)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    if not pathlib.Path(CHROMIUM).exists():
        if os.environ.get("CI"):
            pytest.fail(f"{CHROMIUM} is missing: apt-get install chromium")
        pytest.skip(f"{CHROMIUM} is missing: apt-get install chromium")
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    with sync_api.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
        yield chromium
        chromium.close()


@pytest.fixture
def page(browser: Any) -> Iterator[Any]:
    """A page whose every request is recorded; any to another host than 127.0.0.1 is aborted
    (and fails the test): the view needs no network."""
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    outside: list[str] = []

    def gate(route: Any) -> None:
        host = urllib.parse.urlsplit(route.request.url).hostname
        if host == "127.0.0.1" or route.request.url.startswith("data:"):
            route.continue_()
        else:
            outside.append(route.request.url)
            route.abort()

    context.route("**/*", gate)
    tab = context.new_page()
    errors: list[str] = []
    tab.on("pageerror", lambda exc: errors.append(str(exc)))
    yield tab
    context.close()
    assert outside == [], f"requests that left the machine: {outside}"
    assert errors == [], f"errors in the page: {errors}"


def _rig(
    *args: str, cwd: pathlib.Path, marker: str, stream: str = "stdout"
) -> tuple[subprocess.Popen[str], str]:
    """``rig ARGS`` as a process; the URL from its line that holds ``marker``."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "rig.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=cwd,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    pipe = proc.stdout if stream == "stdout" else proc.stderr
    assert pipe is not None
    for _ in range(200):
        line = pipe.readline()
        if marker in line or not line:
            break
    url = next((w for w in line.split() if w.startswith("http://")), "")
    if not url:
        proc.kill()
        raise AssertionError(f"rig {' '.join(args)}: no address in {line!r}: {proc.communicate()[1][-2000:]}")
    return proc, url


def _stop(proc: subprocess.Popen[str]) -> tuple[str, str]:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        return proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate()


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """Two runs of the servo (different moves), an identification with its frequency response, a
    study of three points, one of which fails (its run outlasts the study's timeout)."""
    from rig.config import load_config
    from rig.host.session import run_config

    base = tmp_path_factory.mktemp("browser")
    runs = base / "runs"
    cfg = load_config(EXAMPLES / "dc_servo_position.toml")
    for distance in (10.0, 5.0):
        run = dataclasses.replace(cfg.run, output=str(runs))
        reference = dataclasses.replace(cfg.reference, distance=distance)
        run_config(dataclasses.replace(cfg, run=run, reference=reference), emulate=True, duration=0.6)
    ident = ["identify", "--emulate", "dc-servo", "--excitation", "multisine", "--f-min", "5"]
    subprocess.run([sys.executable, "-m", "rig.cli", *ident], cwd=base, check=True, capture_output=True)
    spec = base / "study.toml"
    spec.write_text(
        textwrap.dedent(
            f"""\
            [sweep]
            name = "servo-duration"
            base = "{EXAMPLES / "dc_servo_position.toml"}"
            metrics = ["rms_error", "max_error"]
            timeout = 5.0
            output = "sweeps"

            [parameters]
            "run.duration" = {{ values = [0.2, 0.4, 60.0], unit = "s" }}
            """
        )
    )
    subprocess.run(
        [sys.executable, "-m", "rig.cli", "sweep", str(spec), "--workers", "1"],
        cwd=base,
        check=False,
        capture_output=True,
    )
    assert (base / "sweeps" / "servo-duration" / "results.parquet").exists()
    return base


def _shot(page: Any, name: str) -> None:
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)


def test_the_live_scope_advances_during_an_emulated_run(page: Any, tmp_path: pathlib.Path) -> None:
    config = EXAMPLES / "dyno_speed_load.toml"
    argv = ["run", "--config", str(config), "--emulate", "--duration", "600", "--view", "127.0.0.1:0"]
    proc, url = _rig(*argv, cwd=tmp_path, marker="view at", stream="stderr")
    try:
        page.goto(url)
        status = page.locator("#live-status")
        page.wait_for_function("Number(document.querySelector('#live-status').dataset.t) > 0.2", timeout=WAIT)
        first = float(status.get_attribute("data-t"))
        page.wait_for_function(
            f"Number(document.querySelector('#live-status').dataset.t) > {first + 0.2}", timeout=WAIT
        )
        assert page.locator("#live-charts .chart").count() == 4  # motor, encoder, load, loop
        points = int(page.locator("#live-charts .chart").first.get_attribute("data-points"))
        assert points > 100
        assert "OPERATION ENABLED" in page.locator("#live-states").inner_text()
        page.click("#live-pause")
        paused = status.get_attribute("data-t")
        page.wait_for_timeout(500)
        assert status.get_attribute("data-t") == paused  # paused: the picture holds
        first_chart = page.locator("#live-charts .chart").first
        first_chart.locator(".u-over").hover()  # the cursor's readout, with units
        legend = first_chart.locator(".u-legend").inner_text()
        assert "motor.velocity" in legend and " rad/s" in legend and " V" in legend, legend
        page.click("#live-pause")
        page.wait_for_function(
            f"Number(document.querySelector('#live-status').dataset.t) > {float(paused)}", timeout=WAIT
        )
        _shot(page, "live-scope")
        proc.send_signal(signal.SIGINT)
        page.wait_for_selector("#live-summary", timeout=WAIT)
        assert "stopped: Ctrl-C (SIGINT)" in page.locator("#live-summary").inner_text()
        _shot(page, "live-end")
    finally:
        _stop(proc)


@pytest.fixture(scope="module")
def view(folder: pathlib.Path) -> Iterator[str]:
    proc, url = _rig("view", "runs", "sweeps", "--port", "0", cwd=folder, marker="rig view:")
    yield url
    _stop(proc)


def _servo_runs(folder: pathlib.Path) -> list[pathlib.Path]:
    return sorted(p for p in (folder / "runs").iterdir() if p.name.startswith("dc-servo-position"))


def test_a_past_run_s_plot_shows_its_samples_and_two_runs_overlay(
    page: Any, folder: pathlib.Path, view: str
) -> None:
    first, second = _servo_runs(folder)
    rows = len(np.loadtxt(first / "samples.csv", delimiter=",", skiprows=1))
    page.goto(view + "#runs")
    page.click(f"#run-list li[data-name='{first.name}']")
    page.wait_for_selector("#run-charts .run-chart[data-points]", timeout=WAIT)
    assert int(page.locator("#run-charts .run-chart").first.get_attribute("data-points")) == rows == 1500
    assert "cycles" in page.locator("#run-summary").inner_text()
    _shot(page, "run")
    page.select_option("#overlay-with", label=second.name)
    page.wait_for_selector("#overlay-chart[data-points]", timeout=WAIT)
    chart = page.locator("#overlay-chart")
    assert chart.get_attribute("data-runs") == f"{first.name} {second.name}"
    assert int(chart.get_attribute("data-points")) == rows  # the same time grid, joined
    legend = chart.locator(".u-legend").inner_text()
    assert f"measurement ({first.name})" in legend and f"measurement ({second.name})" in legend
    chart.scroll_into_view_if_needed()
    _shot(page, "overlay")


def test_the_trace_filters_by_cob_id(page: Any, folder: pathlib.Path, view: str) -> None:
    import can

    run = _servo_runs(folder)[0]
    tpdo1 = sum(1 for m in can.ASCReader(str(run / "trace.asc")) if m.arbitration_id == 0x181)
    page.goto(view + "#runs")
    page.click(f"#run-list li[data-name='{run.name}']")
    page.wait_for_selector("#trace-table", timeout=WAIT)
    page.fill("#trace-cob", "181")
    page.press("#trace-cob", "Enter")
    page.wait_for_function(
        f"document.querySelector('#trace-count').dataset.matched === '{tpdo1}'", timeout=WAIT
    )
    cells = page.locator("#trace-table tr td:nth-child(2)").all_inner_texts()
    assert cells and set(cells) == {"181"}


def test_a_study_s_table_sorts_and_marks_its_failed_point(page: Any, view: str) -> None:
    page.goto(view + "#studies")
    page.click("#study-list li[data-name='servo-duration']")
    page.wait_for_selector("#sweep-table tbody tr", timeout=WAIT)
    assert page.locator("#sweep-table tr.failed").count() == 1
    header = page.locator("#sweep-table th[data-key='rms_error']")

    def column() -> list[float]:
        """The rms_error cells in the table's order; the failed point's is empty (NaN) and last."""
        index = page.locator("#sweep-table th").all_inner_texts().index("rms_error") + 1
        texts = page.locator(f"#sweep-table tbody tr td:nth-child({index})").all_inner_texts()
        assert len(texts) == 3 and texts[-1].strip() == "", texts  # the failed point last, either way
        return [float(t) for t in texts[:-1]]

    header.click()
    ascending = column()
    assert ascending == sorted(ascending) and len(ascending) == 2
    header.click()
    assert column() == sorted(ascending, reverse=True)
    failed = page.locator("#sweep-table tr.failed").inner_text()
    assert "60" in failed  # the point whose run.duration outlasted the study's timeout
    page.wait_for_selector("#sweep-chart[data-points]", timeout=WAIT)
    _shot(page, "study")


def test_an_identification_s_bode_plot(page: Any, view: str) -> None:
    page.goto(view + "#studies")
    page.click("#ident-list li")
    page.wait_for_selector("#bode-magnitude[data-points]", timeout=WAIT)
    assert int(page.locator("#bode-magnitude").get_attribute("data-points")) > 10
    assert "a_m =" in page.locator("#ident-model").inner_text()
    assert page.locator("#bode-coherence canvas").count() == 1
    _shot(page, "bode")


def test_the_docs_screenshot_is_one_of_these() -> None:
    """docs/images/view-live.png is a screenshot this tier took (refreshed by hand from
    ci-artifacts/browser/live-scope.png)."""
    image = ROOT / "docs" / "images" / "view-live.png"
    assert image.exists() and image.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    if (ARTIFACTS / "live-scope.png").exists():
        shutil.copy(ARTIFACTS / "live-scope.png", ARTIFACTS / "docs-view-live-candidate.png")
