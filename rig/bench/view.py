"""``rig bench view``: what the view costs a 1 kHz real-time run.

``runs`` rounds of three runs, alternated in the same minutes: a real-time 1 kHz run of the
section VII.B servo held at 0 rad (``rig.bench.socketcand.realtime_run``, against ``rig emulate
--preset dc-servo`` at 1 kHz in another process over socketcand) without a view (``plain_``); the
same run with the view served beside it as ``rig run --view`` serves it (``rig.view``: the
recorder writes a ring shared with the view's own process, which reads it, ``rig.view.beside``)
and a browser on this machine: headless Chromium (Playwright, ``/usr/bin/chromium``) showing the
live scope, or where there is none a websocket client (``view_``); and the view served with its
reader elsewhere, as a laptop's browser is: a websocket client in a process of its own that reads
and parses every update as the page does, drawing nothing, at SCHED_IDLE (``remote_``): a reader
on another machine takes none of the rig PC's CPU time, and this stand-in takes only what nothing
else on it wants, so what is measured is what the view itself (its server, the network) costs the
rig PC; its own CPU time a second is given (``remote_reader_cpu``). Each run ``seconds`` long.
Figures, each the median and the range over the runs of its kind: overruns and late cycles (% of
cycles), the period error's p99, the response's median and p99 (the host's SYNC to its RPDOs,
``rig.host.loop_stats``) and the p99 of its two parts: the emulated drive's answer (the SYNC to its
TPDO: on a real rig a drive's, which no browser on the rig PC slows) and the host's own time (that
TPDO to the RPDOs: the toolkit's); with the view, the updates a second the reader received; the
load average before and after.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rig.bench.micro import Figure

__all__ = ["as_if_elsewhere", "bench_view", "browser_process", "main"]

CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run"]
FLAGS += ["--disable-background-networking", "--disable-component-update", "--disable-sync"]


def _has_chromium() -> bool:
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return False
    return Path(CHROMIUM).exists()


def browser_process(url: str, seconds: float, kind: str = "") -> subprocess.Popen[str]:
    """A browser on ``url`` for ``seconds`` in a process of its own; its JSON result on stdout.
    ``kind``: "chromium", "websocket", or "" for Chromium where there is one.

    Parameters
    ----------
    url : str
        The view's address.
    seconds : float
        [s].
    kind : str, optional
        "chromium", "websocket", or "" (Chromium where there is one).

    Returns
    -------
    subprocess.Popen[str]
        The process.
    """
    kind = kind or ("chromium" if _has_chromium() else "websocket")
    return subprocess.Popen(
        [sys.executable, "-m", "rig.bench.view", kind, url, str(seconds)],
        stdout=subprocess.PIPE,
        stderr=tempfile.TemporaryFile(mode="w+"),  # read back when it fails (``_client_result``)
        text=True,
    )


def as_if_elsewhere(pid: int) -> None:
    """Process ``pid`` (a reader standing in for one on another machine) at SCHED_IDLE: it gets the
    CPU time nothing else on this machine wants, as a laptop's browser takes none of the rig PC's.

    Parameters
    ----------
    pid : int
        The process.
    """
    os.sched_setscheduler(pid, os.SCHED_IDLE, os.sched_param(0))


def _client_result(client: subprocess.Popen[str]) -> dict[str, Any]:
    """The browser's JSON result, or what it said when it gave none."""
    got, _ = client.communicate(timeout=120)
    if got.strip():
        result: dict[str, Any] = json.loads(got)
        return result
    err = client.stderr
    said = ""
    if err is not None:
        err.seek(0)
        said = err.read()[-300:].strip().replace("\n", " | ")
    return {"client": f"failed (exit {client.returncode}): {said}", "updates_per_s": 0.0}


def _chromium(url: str, seconds: float) -> dict[str, Any]:
    """The page in headless Chromium for ``seconds``: the updates/s it showed (its own count)."""
    from playwright.sync_api import sync_playwright

    rates = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.goto(url)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            page.wait_for_timeout(1000)
            rate = page.evaluate("document.querySelector('#live-rate').dataset.rate || ''")
            if rate:
                rates.append(float(rate))
        browser.close()
    return {"client": "chromium", "updates_per_s": statistics.median(rates[1:] or rates or [0.0])}


def _websocket(url: str, seconds: float) -> dict[str, Any]:
    """A client that reads and parses every message for ``seconds``: updates/s while rows came."""
    import asyncio

    from websockets.asyncio.client import connect

    async def read() -> dict[str, Any]:
        times: list[float] = []
        async with connect(url.replace("http://", "ws://") + "ws/live", max_size=None) as ws:
            end = time.monotonic() + seconds
            while (left := end - time.monotonic()) > 0:
                try:
                    msg = json.loads(await asyncio.wait_for(ws.recv(), left))
                except (TimeoutError, asyncio.TimeoutError):
                    break
                if msg["type"] == "rows" and msg["rows"]:
                    times.append(time.monotonic())
                if msg["type"] == "end":
                    break
        span = times[-1] - times[0] if len(times) > 1 else 0.0
        return {
            "client": "websocket",
            "updates_per_s": (len(times) - 1) / span if span else 0.0,
            "cpu_per_s": time.process_time() / seconds,  # [s/s] its own, start-up included
        }

    return asyncio.run(read())


def _with_view(
    out: str, port: int, seconds: float, kind: str = "", *, elsewhere: bool = False
) -> tuple[dict[str, Any], dict[str, Any]]:
    """One run with the view beside it as ``rig run --view`` serves it, and a browser attached
    (``kind``: ``browser_process``'s; ``elsewhere``: at SCHED_IDLE, the module docstring): (its
    summary, the browser's)."""
    from rig.bench.socketcand import realtime_run
    from rig.host.realtime import RealtimeRequest, loop_cpu
    from rig.view.beside import SharedView
    from rig.view.process import ViewProcess

    view = ViewProcess(
        [Path(out)], "127.0.0.1", 0, "rig bench view", loop_cpu=loop_cpu(RealtimeRequest().cpu)
    )
    live = SharedView(view.sink, out)
    client = browser_process(view.url, seconds + 15.0, kind)
    if elsewhere:
        as_if_elsewhere(client.pid)
    time.sleep(5.0)  # the browser is up and connected before the cycles begin
    summary: dict[str, Any] = {}
    try:
        summary = realtime_run(
            out,
            port,
            seconds,
            live=live,
            started=live.watch,
        )
    finally:
        view.finish(summary)
    return summary, _client_result(client)


def bench_view(
    *, runs: int = 5, seconds: float = 10.0, progress: Callable[[int, int], None] | None = None
) -> list[Figure]:
    """See the module docstring; ``progress(run, 2 * runs)`` after each run.

    Parameters
    ----------
    runs : int, optional
        Runs with and without the view.
    seconds : float, optional
        [s] of each.
    progress : Callable[[int, int], None] | None, optional
        ``progress(run, 2 * runs)``.

    Returns
    -------
    list[Figure]
        The figures.
    """
    from rig.bench.socketcand import realtime_run
    from rig.emulator.spawn import spawn_emulator, stop_rig

    before = " ".join(f"{x:.2f}" for x in os.getloadavg())
    plain: list[dict[str, Any]] = []
    viewed: list[dict[str, Any]] = []
    remote: list[dict[str, Any]] = []  #: the view served, its reader elsewhere's stand-in
    clients: list[dict[str, Any]] = []
    readers: list[dict[str, Any]] = []
    proc, port = spawn_emulator("--preset", "dc-servo", "--param", "period=0.001")
    try:
        with tempfile.TemporaryDirectory() as out:
            for n in range(runs):
                plain.append(realtime_run(out, port, seconds))
                summary, client = _with_view(out, port, seconds)
                viewed.append(summary)
                clients.append(client)
                summary, client = _with_view(out, port, seconds, "websocket", elsewhere=True)
                remote.append(summary)
                readers.append(client)
                if progress is not None:
                    progress(n + 1, runs)
    finally:
        stop_rig(proc, timeout=20)
    after = " ".join(f"{x:.2f}" for x in os.getloadavg())
    figures: list[Figure] = [
        {"name": "loadavg_before", "value": before, "unit": "1/5/15 min"},
        {"name": "loadavg_after", "value": after, "unit": "1/5/15 min"},
        {"name": "runs", "value": runs, "unit": f"pairs of {seconds:g} s at 1 kHz, alternated"},
        *({"name": "browser", "value": c["client"], "unit": ""} for c in clients),
    ]
    for kind, summaries in (("plain", plain), ("view", viewed), ("remote", remote)):
        figures += _kind_figures(kind, summaries)
    figures += _spread("view_updates_per_s", [c["updates_per_s"] for c in clients], "1/s", 1)
    figures += _spread("remote_updates_per_s", [c["updates_per_s"] for c in readers], "1/s", 1)
    cpu = [1e3 * c["cpu_per_s"] for c in readers if "cpu_per_s" in c]
    figures += _spread("remote_reader_cpu", cpu, "ms per s (its own, at SCHED_IDLE)", 1)
    return figures


#: the summaries' timing figures each kind of run gives (``rig.host.loop_stats``)
_TIMING = (
    "period_error_p99_us",
    "response_median_us",
    "response_p99_us",
    "drive_answer_p99_us",
    "host_time_p99_us",
)


def _kind_figures(kind: str, summaries: list[dict[str, Any]]) -> list[Figure]:
    """The figures of one kind of run (``plain``, ``view``, ``remote``) from their summaries:
    overruns and late cycles, the period error's p99, the response's median and p99 and the p99 of
    its parts (the drive's answer, the host's own time), stops."""
    figures = _spread(f"{kind}_overruns", [_share(s, "overruns") for s in summaries], "% of cycles", 3)
    figures += _spread(f"{kind}_late", [_share(s, "late_cycles") for s in summaries], "% of cycles", 3)
    for key in _TIMING:
        values = [float(s.get("timing", {}).get(key, float("nan"))) for s in summaries]
        figures += _spread(f"{kind}_{key[:-3]}", values, "us", 1)
    stops = sum(1 for s in summaries if s.get("safe_stop_reason"))
    figures.append({"name": f"{kind}_stops", "value": stops, "unit": "runs"})
    return figures


def _share(summary: dict[str, Any], key: str) -> float:
    cycles = max(1, int(summary.get("cycles", 0)) + int(summary.get("overruns", 0)))
    return 100.0 * float(summary.get(key, 0)) / cycles


def _spread(name: str, values: list[float], unit: str, digits: int) -> list[Figure]:
    """The median and the range of ``values``."""
    if not values:
        return []
    return [
        {"name": f"{name}_median", "value": round(statistics.median(values), digits), "unit": unit},
        {
            "name": f"{name}_range",
            "value": f"{min(values):.{digits}f} .. {max(values):.{digits}f}",
            "unit": unit,
        },
    ]


def _range(values: list[float], digits: int) -> str:
    return f"{min(values):.{digits}f} .. {max(values):.{digits}f}"


def main(argv: list[str]) -> int:
    """``chromium|websocket URL SECONDS``: one browser's JSON result on stdout.

    Parameters
    ----------
    argv : list[str]
        ``chromium|websocket URL SECONDS``.

    Returns
    -------
    int
        The exit status.
    """
    kind, url, seconds = argv[0], argv[1], float(argv[2])
    result = _chromium(url, seconds) if kind == "chromium" else _websocket(url, seconds)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
