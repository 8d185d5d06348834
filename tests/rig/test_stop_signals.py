"""Signals, one rule (docs/cli.md, "Exit codes and stop signals"): a stop signal is the one safe
stop of every command, which then prints no result, one line on stderr, and exits 128 + the
signal's number; a study of many runs ends with the run the signal stopped; ``rig`` answers
SIGINT and SIGTERM whatever its parent set. Deterministic: ``rig.cli.main`` runs the command in
this process and the signal is raised in it at a known point (the first progress step of a
run's loop, a look of a jog, the first row of a sweep). The same across real processes, on the
clock: ``test_stop_signals_processes.py`` (timing tier).
"""

from __future__ import annotations

import json
import pathlib
import re
import signal
from collections.abc import Callable
from typing import Any

import pytest

from rig.cli import main
from rig.cli.common import EXIT_CODES
from rig.host.loop import HostLoop
from rig.host.signals import StopRequests, forget

ROOT = pathlib.Path(__file__).resolve().parents[2]
SERVO = ROOT / "examples" / "dc_servo_position.toml"
DRIVES_QUICK = ["speed_t_end=0.5", "servo_t_end=0.5", "servo_settle=0.25", "im_t_end=0.5"]
CONFIRMED = "every drive stopped, at rest and disabled"


@pytest.fixture
def in_run(monkeypatch: pytest.MonkeyPatch) -> Callable[[signal.Signals], list[int]]:
    """``in_run(sig)``: each run's loop raises ``sig`` in this process at its first progress step
    (1 % of its cycles); returns the list of the loops that ran (one entry each)."""

    def arm(sig: signal.Signals) -> list[int]:
        original = HostLoop.run
        loops: list[int] = []

        def run(self: HostLoop, progress: Callable[[int], None] | None = None) -> dict[str, Any]:
            loops.append(self.cycles)
            fired = [False]

            def step(k: int) -> None:
                if not fired[0]:
                    fired[0] = True
                    signal.raise_signal(sig)
                if progress is not None:
                    progress(k)

            return original(self, step)

        monkeypatch.setattr(HostLoop, "run", run)
        return loops

    return arm


def _said(err: str) -> str:
    """The last line on stderr: the command's word on its stop."""
    return err.strip().splitlines()[-1]


@pytest.fixture
def here(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> pathlib.Path:
    """``tmp_path``, the working folder (runs/ goes there)."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_a_run_stopped_by_a_signal_prints_no_summary_and_exits_128_plus_its_number(
    here: pathlib.Path, capsys: pytest.CaptureFixture[str], in_run: Callable[[signal.Signals], list[int]]
) -> None:
    """Was: the summary printed as a run's result, exit 3 (as a safety stop)."""
    in_run(signal.SIGTERM)
    assert main(["run", "--config", str(SERVO), "--emulate", "--duration", "2"]) == 128 + signal.SIGTERM
    out, err = capsys.readouterr()
    assert out == ""
    (run_dir,) = (p.parent for p in here.glob("runs/*/summary.json"))
    assert _said(err) == (
        f"rig run: stopped by SIGTERM (terminate); {CONFIRMED}; what was done is in runs/{run_dir.name}"
    )
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["safe_stop_reason"] == "SIGTERM (terminate)" and summary["stop_confirmed"] is True
    assert 0 < summary["cycles"] < 5000 and not (run_dir / "plot.png").exists()  # the plot: not drawn
    assert (run_dir / "samples.mat").exists()


@pytest.mark.parametrize(
    ("argv", "who"),
    [
        (["reproduce", "drives", *(a for p in DRIVES_QUICK for a in ("--param", p))], "rig reproduce drives"),
        (["faults", "--scenario", "tpdo-stall", "--scenario", "over-current-emcy"], "rig faults"),
    ],
    ids=["reproduce-drives", "faults"],
)
def test_a_study_ends_with_the_run_a_signal_stopped(
    argv: list[str],
    who: str,
    capsys: pytest.CaptureFixture[str],
    in_run: Callable[[signal.Signals], list[int]],
) -> None:
    """``rig reproduce drives`` (its pure simulations, then its first run over the bus) and
    ``rig faults`` (two scenarios): Ctrl-C in the first run; no further run, no table. Was: every
    other run, then the tables with the cut-short run among them as a result, exit 0. Their
    runs were in a temporary folder: none is named."""
    loops = in_run(signal.SIGINT)
    assert main(argv) == 128 + signal.SIGINT
    out, err = capsys.readouterr()
    assert out == "" and len(loops) == 1
    assert _said(err) == f"{who}: stopped by Ctrl-C (SIGINT); {CONFIRMED}"


def test_an_identification_a_signal_stopped_identifies_nothing(
    here: pathlib.Path, capsys: pytest.CaptureFixture[str], in_run: Callable[[signal.Signals], list[int]]
) -> None:
    """Was: exit 3, as for a safety stop of its experiment."""
    in_run(signal.SIGINT)
    assert main(["identify", "--emulate", "dc-servo"]) == 128 + signal.SIGINT
    out, err = capsys.readouterr()
    assert out == "" and not list(here.glob("runs/*/identification.json"))
    assert re.fullmatch(
        rf"rig identify: stopped by Ctrl-C \(SIGINT\); {CONFIRMED}; what was done is in runs/identify-\S+",
        _said(err),
    )


def test_a_jog_a_signal_stopped_ends_in_its_stop_with_no_result(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    """``rig drive jog``: Ctrl-C at the jog's fifth look, and again during its stop (which it
    does not cut); the drive's quick stop, ramp and disable, confirmed. Was: the result table
    ("interrupted (Ctrl-C)") and exit 3; a second Ctrl-C cut the stop."""
    from rig.commission.drive import DriveTool

    looks, stop = [0], DriveTool.stop

    def look(self: DriveTool) -> None:
        looks[0] += 1
        if looks[0] == 5:
            signal.raise_signal(signal.SIGINT)

    def stopping(self: DriveTool, **kw: Any) -> tuple[bool, dict[str, float | None]]:
        signal.raise_signal(signal.SIGINT)  # the second Ctrl-C: logged, the stop goes on
        return stop(self, **kw)

    monkeypatch.setattr(DriveTool, "_look", look)
    monkeypatch.setattr(DriveTool, "stop", stopping)
    assert main(["drive", "--emulate", "epos4", "jog", "10", "--for", "2"]) == 128 + signal.SIGINT
    out, err = capsys.readouterr()
    assert out == "" and looks[0] >= 5
    assert "Ctrl-C (SIGINT) while stopping: the stop goes on" in caplog.text
    assert _said(err) == f"rig drive jog: stopped by Ctrl-C (SIGINT); {CONFIRMED}"


def test_a_signal_while_the_jog_enables_the_drive_is_the_jogs_stop(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Ctrl-C as the drive reaches OPERATION ENABLED, before the jog's target: the jog's own stop
    (quick stop, disable, confirmed), not the command's end with the drive left to the close. Was:
    'stopped by Ctrl-C (SIGINT)' and no stop of the jog's (found by the timing tier's jog, whose
    signal came as the drive enabled at a load of 24)."""
    from drivers.cia402 import Cia402Axis
    from rig.commission.drive import DriveTool

    enable, stops = Cia402Axis.enable, []

    def enabling(self: Cia402Axis, *args: Any, **kw: Any) -> None:
        enable(self, *args, **kw)
        signal.raise_signal(signal.SIGINT)

    def stopping(self: DriveTool, **kw: Any) -> tuple[bool, dict[str, float | None]]:
        stops.append(self.axis.read_power_state().value)
        return stop(self, **kw)

    stop = DriveTool.stop
    monkeypatch.setattr(Cia402Axis, "enable", enabling)
    monkeypatch.setattr(DriveTool, "stop", stopping)
    assert main(["drive", "--emulate", "epos4", "jog", "10", "--for", "2"]) == 128 + signal.SIGINT
    out, err = capsys.readouterr()
    assert out == "" and stops == ["OPERATION ENABLED"]
    assert _said(err) == f"rig drive jog: stopped by Ctrl-C (SIGINT); {CONFIRMED}"


def test_a_sweep_a_signal_stopped_keeps_its_rows_and_prints_no_summary(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``rig sweep`` on a cluster in this process (threads): Ctrl-C once the first row is in;
    the row kept, the table named, no summary (was: the summary and "interrupted" on stdout)."""
    from dask.distributed import LocalCluster

    from rig.cli.progress import Progress

    spec = tmp_path / "spec.toml"
    spec.write_text(
        f'[sweep]\nname = "cut"\nscenario = "dismc"\noutput = "{tmp_path / "sweeps"}"\n'
        '[parameters]\nu_bound = { from = 30.0, to = 300.0, num = 6, scale = "log" }\n'
    )

    def update(self: Progress, done: float, note: str = "") -> None:
        signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(Progress, "update", update)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as cluster:
        code = main(["sweep", str(spec), "--scheduler", cluster.scheduler_address])
    assert code == 128 + signal.SIGINT
    out, err = capsys.readouterr()
    table = tmp_path / "sweeps" / "cut" / "results.parquet"
    assert out == ""
    assert "rig sweep: 1 of 6 points done; --resume runs the others" in err
    assert _said(err) == f"rig sweep: stopped by Ctrl-C (SIGINT); what was done is in {table}"


def test_rig_answers_sigint_and_sigterm_whatever_the_parent_set(monkeypatch: pytest.MonkeyPatch) -> None:
    """A script's background job starts with SIGINT ignored; a parent may block SIGTERM (the
    mask is inherited across exec); ``nohup`` ignores SIGHUP. During a command SIGINT and SIGTERM
    are answered and unblocked, SIGHUP stays ignored; after ``main`` all is as it was. Was:
    SIGINT left ignored by the console script ``rig`` (only ``python -m rig.cli`` undid it)."""
    import rig.cli.export

    seen: dict[str, Any] = {}

    def handler(args: object) -> int:
        seen.update({s.name: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)})
        seen["blocked"] = signal.pthread_sigmask(signal.SIG_BLOCK, set())
        return 0

    monkeypatch.setattr(rig.cli.export, "run", handler)
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGHUP)}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        assert main(["export", "runs/x", "--format", "csv"]) == 0
        assert callable(seen["SIGINT"]) and callable(seen["SIGTERM"])  # rig's: the stop
        assert seen["SIGHUP"] is signal.SIG_IGN and signal.SIGTERM not in seen["blocked"]
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert signal.SIGTERM in signal.pthread_sigmask(signal.SIG_BLOCK, set())
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for sig, was in before.items():
            signal.signal(sig, was)


def test_a_session_leaves_an_ignored_sighup_ignored() -> None:
    """``nohup rig run ...`` outlives its terminal (was: a hang-up stopped it all the same)."""
    forget()
    before = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    requests = StopRequests()
    try:
        requests.install()
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) == requests._on_signal
    finally:
        requests.restore()
        signal.signal(signal.SIGHUP, before)


def test_docs_cli_gives_the_exit_codes_the_code_has() -> None:
    """docs/cli.md's table is ``rig.cli.common.EXIT_CODES``, which ``rig --help`` prints."""
    text = (ROOT / "docs" / "cli.md").read_text()
    section = text.split("## Exit codes and stop signals", 1)[1]
    found = re.search(r"\n(\| code \|.*?)\n\n", section, re.S)
    assert found is not None
    rows = [line.strip("|").split("|", 1) for line in found.group(1).splitlines()[2:]]
    table = {code.strip(): words.strip().replace("`", "").replace("\\|", "|") for code, words in rows}
    assert table == EXIT_CODES


@pytest.mark.parametrize("code", [0, 1, 2, 3, 4, 129, 130, 143])
def test_a_command_a_signal_ended_skips_the_interpreters_teardown(
    monkeypatch: pytest.MonkeyPatch, code: int
) -> None:
    """``rig.cli.entry`` (the console script and ``python -m rig.cli``): after a stop signal (exit
    128 + N, or 4: unconfirmed) the exit handlers run, the output is flushed and the process ends
    at once (``os._exit``), without the interpreter's teardown that took 1.2-2.5 s of the 2 s at a
    load of 23 (test_stop_signals_processes measured 3.7-4.4 s for run, jog, identify,
    reproduce drives, faults and demo); any other end is ``sys.exit``'s, teardown and all."""
    import atexit
    import os

    import rig.cli

    ran: list[str] = []
    monkeypatch.setattr(rig.cli, "main", lambda: code)
    monkeypatch.setattr(atexit, "_run_exitfuncs", lambda: ran.append("atexit"))

    def end_now(status: int) -> None:
        ran.append(f"os._exit({status})")
        raise SystemExit(status)  # as os._exit would end it, without ending pytest

    monkeypatch.setattr(os, "_exit", end_now)
    with pytest.raises(SystemExit) as ended:
        rig.cli.entry()
    assert ended.value.code == code
    assert ran == (["atexit", f"os._exit({code})"] if code in (4, 129, 130, 143) else [])
