"""The progress line: on a terminal only, not with --json, redrawn at most a few times a second,
ended by close; and rig run draws it through the loop's 1 % callback."""

from __future__ import annotations

import io
import pathlib

import pytest

from rig.cli.progress import Progress

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_terminal_gets_done_total_elapsed_and_left() -> None:
    out = Terminal()
    bar = Progress("rig run", 0, "cycles", stream=out, rate=1e9)
    for k in range(75, 7501, 75):
        bar.cycles(k, 7500)
    bar.close()
    text = out.getvalue()
    assert "\rrig run: 7,500/7,500 cycles (100 %)" in text and "s left" in text and text.endswith("\n")


@pytest.mark.parametrize(("stream", "json"), [(io.StringIO(), False), (Terminal(), True)])
def test_nothing_for_a_file_or_json(stream: io.StringIO, json: bool) -> None:
    bar = Progress("rig run", 100, "cycles", json=json, stream=stream)
    bar.update(50)
    bar.close()
    assert stream.getvalue() == ""


def test_at_most_rate_redraws() -> None:
    out = Terminal()
    bar = Progress("x", 1_000_000, "cycles", stream=out, rate=1.0)
    for k in range(1000):
        bar.update(k)
    assert out.getvalue().count("\r") == 1  # the first draw; the next is due in 1 s


def test_rig_run_draws_it(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    from rig.cli import main

    out = Terminal()
    monkeypatch.setattr(sys, "stderr", out)
    config = tmp_path / "rig.toml"
    config.write_text(EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path}"'))
    assert main(["run", "--config", str(config), "--emulate", "--duration", "0.2"]) == 0
    assert "rig run: 500/500 cycles (100 %)" in out.getvalue()


def test_rig_reproduce_drives_draws_its_parts(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    from rig.cli import main

    out = Terminal()
    monkeypatch.setattr(sys, "stderr", out)
    monkeypatch.setattr(sys, "stdout", io.StringIO())
    params = ["speed_t_end=0.5", "servo_t_end=0.5", "servo_settle=0.25", "im_t_end=0.5", "bus=false"]
    assert main(["reproduce", "drives", *(a for p in params for a in ("--param", p))]) == 0
    assert "rig reproduce drives: 6/6 parts (100 %)" in out.getvalue()
