"""``[controller] speed = "observer"``: the VII.B servo over the emulated bus with the speed
estimated from the drive's 4096-count position, within 2x of the exact pure simulation's rms
error; a wrong value is one line naming it."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from rig.cli import main
from rig.papers.scenarios import position_servo_run
from rig.report.metrics import rms

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"


def _config(tmp_path: pathlib.Path, speed: str) -> str:
    text = EXAMPLE.read_text().replace('output = "runs"', f'output = "{tmp_path}"')
    path = tmp_path / "rig.toml"
    path.write_text(text.replace("u0 = 48.0\n", f'u0 = 48.0\nspeed = "{speed}"\n'))
    return str(path)


def test_the_observed_servo_over_the_bus(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--config", _config(tmp_path, "observer"), "--emulate", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    exact = position_servo_run(load=1000.0, full_motor=True, t_end=3.0)
    assert summary["cycles"] == 7500
    assert summary["rms_error"] < 2.0 * rms(exact.error), (summary["rms_error"], rms(exact.error))


def test_a_wrong_speed_source_is_named(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--config", _config(tmp_path, "psychic"), "--emulate"]) == 2
    err = capsys.readouterr().err
    needle = "[controller] position-servo: speed = 'psychic': expected one of drive, observer"
    assert needle in err and len(err.strip().splitlines()) == 1, err


def _servo_speeds(skip: set[int], *, zero: bool = False, tell: bool = True) -> list[float]:
    """The law with ``speed = "observer"`` on the exact model of its design closing the loop on a
    moving reference; the cycles in ``skip`` bring no sample (the law is not stepped, the drive
    holds its command); the observer's speed error [rad/s] at each step."""
    from controllers.discretize import zoh
    from drivers.base import Feedback
    from rig.laws.position_servo import PositionServoLaw, ServoParams

    period = 0.4e-3
    params = ServoParams(a_m=16.0, b_m=680.0, lam=-15.0, sigma=10.0, h=16.0, u0=48.0, speed="observer")
    law = PositionServoLaw(params, period=period, reference=lambda t: (2.0 * t, 2.0))
    phi, gamma = zoh([[0.0, 1.0], [0.0, -16.0]], [[0.0], [680.0]], dt=period)
    x, u, errors = np.zeros(2), 0.0, []
    for k in range(2000):
        if k not in skip:
            u = law.step(k * period, [Feedback(position=float(x[0]), stamp=float(k))]).commands[0]
            errors.append(law.observer.omega - x[1])  # type: ignore[union-attr]
        elif zero:  # missed_sample = "zero": the drive gets 0 V until the next step
            u = 0.0
            if tell:
                law.held((u,))
        x = phi @ x + (gamma * u).reshape(2)
    return errors


def test_the_observer_runs_through_cycles_without_a_sample() -> None:
    """A cycle the host skipped or whose TPDO came late leaves the law unstepped while the shaft
    moves on under the held command: the law's next step predicts through the periods that passed
    (their count from its time), so the speed it acts on stays the shaft's; stepped as if one
    period had passed, the estimate jumps by the missed travel (measured in real time at 0.4 ms:
    each such cycle knocked the servo off lock-step's trajectory for tenths of a second)."""
    clean = _servo_speeds(set())
    holes = _servo_speeds({700, 1200, 1201})
    assert max(abs(e) for e in clean[200:]) < 1e-3
    assert max(abs(e) for e in holes[200:]) < 1e-3, max(abs(e) for e in holes[200:])


def test_the_observer_knows_the_neutral_command_sent_without_a_step() -> None:
    """With ``missed_sample = "zero"`` a cycle without a sample sends 0 V, which the drive holds
    until the next step: ``Law.held`` tells the law, and its observer predicts with it; told
    nothing, it predicted with the last command the law had computed."""
    holes = {700, 1200, 1201}
    told = _servo_speeds(holes, zero=True)
    untold = _servo_speeds(holes, zero=True, tell=False)
    assert max(abs(e) for e in told[200:]) < 1e-3, max(abs(e) for e in told[200:])
    assert max(abs(e) for e in untold[200:]) > 1e-2
