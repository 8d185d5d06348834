"""The live view (issue 19 item 6): which columns are each axis's, the terminal strip's text, the
window's figure (Agg, no display), and that a run with a viewer, even one that blocks or fails,
ends as the same run without one."""

from __future__ import annotations

import io
import json
import logging
import math
import pathlib
import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest

from rig.cli import main
from rig.config import load_config
from rig.host.session import run_config
from rig.live import Channel, LiveView, channels_of
from rig.live.terminal import ASCII, TerminalStrip, sparkline, strip_lines
from rig.live.view import Ring

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
DYNO = EXAMPLES / "dyno_speed_load.toml"
SERVO = EXAMPLES / "dc_servo_position.toml"

#: the dyno's columns as HostLoop.columns makes them (the IDTSM has no internals), and their units
COLUMNS = [
    "t", "reference", "measurement", "command", "motor.position", "motor.velocity", "motor.current",
    "encoder.position", "encoder.velocity", "load.velocity", "load.torque", "motor.command",
    "load.command", "read_us", "update_us", "write_us",
]  # fmt: skip
UNITS = {"t": "s", "reference": "rad/s", "measurement": "rad/s", "command": "V", "motor.command": "V"}
UNITS |= {"load.command": "N m", "load.torque": "N m", "motor.current": "A"}
DOCS = {c: {"unit": UNITS.get(c, "rad/s" if "velocity" in c else "rad"), "meaning": ""} for c in COLUMNS}
MODES = {"motor": "voltage", "encoder": None, "load": "cst"}


def _channels() -> list[Channel]:
    return channels_of(COLUMNS, DOCS, ["encoder"], MODES)


def _row(t: float, ref: float, meas: float, u: float, torque: float = 0.0) -> list[float]:
    row = [0.0] * len(COLUMNS)
    row[:4] = [t, ref, meas, u]
    row[COLUMNS.index("motor.velocity")] = meas + 0.5
    row[COLUMNS.index("load.torque")] = torque
    row[COLUMNS.index("motor.command")] = u
    row[COLUMNS.index("load.command")] = -torque
    return row


def test_each_axis_gets_its_reference_measurement_and_command() -> None:
    motor, encoder, load = _channels()
    assert encoder == Channel("encoder", 1, 2, None, "law", ("rad/s", "rad/s", ""))
    assert motor == Channel("motor", None, 5, 11, "velocity", ("", "rad/s", "V"))
    assert load == Channel("load", None, 10, 12, "torque", ("", "N m", "N m"))


def test_the_strip_of_given_rows() -> None:
    rows = [_row(k * 0.1, 100.0, 100.0 - e, 2.0, 0.2) for k, e in enumerate([4.0, 2.0, 1.0, 0.0])]
    assert strip_lines(_channels(), rows, blocks=ASCII) == [
        "live  t = 0.300 s",
        "  motor    ref          -        meas      100.5 rad/s  cmd          2 V",
        "  encoder  ref        100 rad/s  meas        100 rad/s  cmd          -        |e| #=:  max 4 rad/s",
        "  load     ref          -        meas        0.2 N m    cmd       -0.2 N m",
    ]
    assert strip_lines(_channels(), [])[0] == "live  waiting for the first cycle"


def test_the_sparkline_scales_to_its_largest() -> None:
    assert sparkline([0.0, 1.0, 2.0, 4.0, 8.0, 8.0, 0.0, 0.0], width=4) == "▂▅█▁"
    assert sparkline([0.0, 0.0]) == "▁▁" and sparkline([]) == ""
    assert sparkline([math.nan, 1.0], width=2) == "▁█"


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_terminal_gets_the_block_redrawn_in_place() -> None:
    out = Terminal()
    strip = TerminalStrip(out)
    strip.open(_channels(), "dyno")
    strip.draw([_row(0.0, 100.0, 99.0, 1.0)])
    strip.draw([_row(0.1, 100.0, 99.5, 1.0)], final=True)
    first, second = out.getvalue().split("\x1b[4F")  # up 4 lines: the header and 3 axes
    assert first.count("\x1b[2K") == 4 and "t = 0.100 s" in second


SAME = ("cycles", "rms_error", "max_error", "chattering_count", "chattering_amplitude", "overruns")
SAME += ("held_cycles", "safe_stop_reason", "stop_confirmed", "axes")


def _samples(summary: dict[str, Any]) -> np.ndarray:
    """The run's samples without the stage timing (3 columns of wall time)."""
    data = np.loadtxt(pathlib.Path(summary["run_dir"]) / "samples.csv", delimiter=",", skiprows=1)
    return data[:, :-3]


def _same_run(a: dict[str, Any], b: dict[str, Any]) -> None:
    assert {k: a[k] for k in SAME} == {k: b[k] for k in SAME}
    np.testing.assert_array_equal(_samples(a), _samples(b))


def test_rig_run_live_terminal_ends_as_the_run_without(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["run", "--config", str(DYNO), "--emulate", "--duration", "0.3", "--json"]
    assert main(argv) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main([*argv, "--live=terminal"]) == 0
    out, err = capsys.readouterr()
    _same_run(plain, json.loads(out))
    last = err[err.rindex("live  t = ") :].splitlines()
    assert last[0] == "live  t = 0.300 s" and [line.split()[0] for line in last[1:]] == list(MODES)
    assert "rad/s" in last[2] and "|e|" in last[2] and "N m" in last[3]


class Blocking:
    """A backend whose first draw does not return until the test lets it."""

    def __init__(self) -> None:
        self.entered, self.release = threading.Event(), threading.Event()
        self.draws = 0

    def open(self, channels: Sequence[Channel], title: str) -> None:
        self.channels = channels

    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        self.draws += 1
        self.entered.set()
        self.release.wait()

    def close(self) -> None:
        pass


def test_a_viewer_that_blocks_never_holds_the_loop(caplog: pytest.LogCaptureFixture) -> None:
    cfg = load_config(SERVO)
    plain = run_config(cfg, emulate=True, duration=0.2)
    backend = Blocking()
    live = LiveView(backend, join_timeout=0.0)

    def progress(k: int, n: int) -> None:  # the viewer is inside its draw before the loop goes on
        assert backend.entered.wait(30.0)

    watched = run_config(cfg, emulate=True, duration=0.2, progress=progress, live=live)
    assert backend.draws == 1  # still in its first draw: the whole run went past it
    assert len(live.rows) == watched["cycles"] == 500  # every row reached the view all the same
    backend.release.set()
    assert live._thread is not None
    live._thread.join(30.0)
    _same_run(plain, watched)
    assert "the live view did not stop within 0 s" in caplog.text


class Failing(Blocking):
    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        self.draws += 1
        if rows:
            raise RuntimeError("boom")


def test_a_viewer_that_fails_is_one_warning_and_the_run_goes_on(caplog: pytest.LogCaptureFixture) -> None:
    cfg = load_config(SERVO)
    plain = run_config(cfg, emulate=True, duration=0.2)
    live = LiveView(Failing())
    with caplog.at_level(logging.WARNING):
        watched = run_config(cfg, emulate=True, duration=0.2, live=live)
    _same_run(plain, watched)
    assert live.failed == "RuntimeError: boom"
    assert caplog.text.count("live view stopped: RuntimeError: boom (the run goes on)") == 1


def test_ctrl_c_stops_the_run_and_the_strip(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["run", "--config", str(SERVO), "--emulate", "--duration", "0.3", "--live=terminal"]
    assert main([*argv, "--fault", "interrupt_at=0.1"]) == 3
    err = capsys.readouterr().err
    assert err.rstrip().splitlines()[-2] == "live  t = 0.100 s"  # the last row before the stop


def test_the_window_s_figure_without_a_display() -> None:
    from matplotlib.figure import Figure

    from rig.live.window import build_figure, update_figure, window_points

    channels = _channels()
    rows = [_row(k * 1e-3, 100.0, 100.0 * (1 - math.exp(-k / 50)), 2.0) for k in range(1000)]
    points = window_points(channels, rows, after=0.5, most=100)
    assert points.shape == (100, 1 + 3 * 3) and points[-1, 0] == rows[-1][0] and points[0, 0] > 0.5
    fig = Figure()
    lines = build_figure(fig, channels, "dyno-speed-load-1")
    update_figure(lines, points)
    fig.canvas.draw()
    assert fig.get_suptitle() == "live: dyno-speed-load-1"
    axes = fig.get_axes()
    assert [ax.get_ylabel() for ax in axes[2:4]] == ["encoder [rad/s]", "command"]
    assert axes[0].get_ylabel() == "motor [rad/s]" and axes[1].get_ylabel() == "command [V]"
    assert [t.get_text() for t in axes[2].get_legend().get_texts()] == ["reference", "measurement"]
    assert axes[5].get_legend() is not None and axes[-1].get_xlabel() == "time [s]"
    assert len(lines[1]["measurement"].get_xdata()) == 100


def test_the_window_s_process_draws_until_the_end() -> None:
    import multiprocessing

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rig.live.window import _show, window_points

    host, window = multiprocessing.Pipe()
    rows = [_row(k * 1e-3, 100.0, 99.0, 2.0) for k in range(10)]
    host.send(("open", _channels(), "run"))
    host.send(("rows", window_points(_channels(), rows, -math.inf)))
    host.send(("end",))
    fig = plt.figure()
    _show(window, plt, fig)
    assert not plt.fignum_exists(fig.number)  # closed at the end
    assert fig.get_suptitle() == "live: run" and len(fig.get_axes()[2].lines[0].get_xdata()) == 10


@pytest.mark.parametrize(
    ("env", "problem"),
    [
        ({}, "no display (DISPLAY and WAYLAND_DISPLAY are not set)"),
        ({"DISPLAY": ":99", "MPLBACKEND": "agg"}, "matplotlib has no window backend here (it chose agg)"),
    ],
)
def test_a_window_that_cannot_open_is_one_line_and_exit_2(
    env: dict[str, str],
    problem: str,
    opened: list[str],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "MPLBACKEND"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    assert main(["run", "--config", str(SERVO), "--emulate", "--live=window"]) == 2
    assert capsys.readouterr().err == f"rig run: --live=window: {problem}\n"
    assert opened == []


def test_no_matplotlib_is_named(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("rig.live.view.importlib.util.find_spec", lambda name: None)
    assert main(["drive", "--emulate", "epos4", "jog", "1", "--for", "0.1", "--live=window"]) == 2
    err = capsys.readouterr().err
    assert err == "rig drive: --live=window: matplotlib is not installed (pip install matplotlib)\n"


def test_rig_drive_jog_live(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["drive", "--emulate", "epos4", "jog", "10", "--for", "0.5", "--live=terminal"]) == 0
    out, err = capsys.readouterr()
    assert "done" in out
    last = err.rstrip().splitlines()[-1]
    assert last.startswith("  node 1  ref         10 rad/s  meas") and "cmd         10 rad/s" in last


def test_the_help_says_how(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["run", "--help"])
    assert exited.value.code == 0  # the help, not a usage error
    text = " ".join(capsys.readouterr().out.split())
    assert "--live [{terminal,window}]" in text and "--emulate --live=terminal" in text


def test_the_view_draws_in_the_loop_s_slack() -> None:
    """Cued, the ring says when the next row comes (the loop appends it at its cycle's end, just
    before it sleeps): the viewer draws then, not at an instant of its own; uncued, an append sets
    nothing, and a cue with no row comes back after its timeout."""
    ring = Ring(4)
    ring.append([0.0])
    assert not ring.ready.is_set()
    got: list[bool] = []
    waiter = threading.Thread(target=lambda: got.append(ring.cue(30.0)))
    waiter.start()
    until = time.monotonic() + 30.0
    while not ring.armed and time.monotonic() < until:  # the viewer has cued it (polled, not timed)
        time.sleep(0.001)
    assert ring.armed
    ring.append([0.001])
    waiter.join(30.0)
    assert got == [True] and not ring.armed
    assert list(ring) == [[0.0], [0.001]]
    assert ring.cue(0.0) is False  # no row within the timeout: the viewer draws all the same
    for k in range(10):
        ring.append([float(k)])
    assert len(ring) == 4  # the latest ``keep`` rows


class Recording(Blocking):
    """A backend that keeps each draw's rows."""

    def __init__(self) -> None:
        super().__init__()
        self.drawn: list[list[Sequence[float]]] = []

    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        self.drawn.append(list(rows))
        self.entered.set()


def test_the_viewer_cues_the_ring_and_draws_the_row_that_ends_the_cycle() -> None:
    """Between two draws the viewer arms its ring (the recorder's): the row the loop appends at its
    cycle's end wakes it, and the next draw holds that row."""
    backend = Recording()
    live = LiveView(backend, rate=100.0, keep=8)
    live.start(_channels(), "slack")
    try:
        assert backend.entered.wait(30.0)
        until = time.monotonic() + 30.0
        while not live.rows.armed and time.monotonic() < until:  # after its pause, it waits for a row
            time.sleep(0.001)
        assert live.rows.armed
        row = _row(0.001, 1.0, 0.5, 2.0)
        live.rows.append(row)
        while not any(row in rows for rows in backend.drawn) and time.monotonic() < until:
            time.sleep(0.001)
        assert any(row in rows for rows in backend.drawn)
    finally:
        live.stop()
