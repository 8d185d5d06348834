"""A position reference starts where the axis stands, and a position command never lurches.

A real drive's encoder reads wherever the shaft was left, not 0. A move of ``distance``
(``[reference] origin = "start"``, the default) goes from there; an absolute reference
(``origin = "zero"``) that starts away from the shaft is refused by the guard before the
first command, and the drive is stopped by its own ramp. Lock-step on the emulated
drives, the shaft turned away from 0 before the run.
"""

from __future__ import annotations

import dataclasses
import pathlib
import re

import numpy as np
import pytest

from rig.config import load_config
from rig.host.rundir import read_samples
from rig.host.session import Session

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
START = 5.0  #: [rad] where the shaft stands before the run
QUANTUM = 2e-3  #: [rad] > one increment of the emulated encoders (2 pi / 4096)


def _run(tmp_path: pathlib.Path, example: str, origin: str, *, start: float = START, **limits: float):  # type: ignore[no-untyped-def]
    cfg = load_config(EXAMPLES / example)
    axis = cfg.axes[0]
    params = {k: v for k, v in cfg.emulator.params.items() if k != "load"}  # its pulse is past 1.5 s
    cfg = dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=1.5),
        emulator=dataclasses.replace(cfg.emulator, params=params),
        reference=dataclasses.replace(cfg.reference, origin=origin),
        axes=(dataclasses.replace(axis, limits=dataclasses.replace(axis.limits, **limits)),),
    )
    with Session(cfg, emulate=True) as session:
        assert session.transport.emulation is not None and session.transport.emulation.bench is not None
        drive = session.transport.emulation.bench.devices[0]
        drive.shaft.motion.x[0] = start  # type: ignore[attr-defined]
        session.start()
        summary = session.run()
        final = drive.shaft.position  # type: ignore[attr-defined]
        if cfg.axes[0].mode == "csp":  # the target the drive was left with [rad]
            summary["left_target"] = drive.od.read(0x607A, 0) / drive.counts_per_rad  # type: ignore[attr-defined]
    _, samples = read_samples(summary["run_dir"])
    return summary, samples, final


def test_a_csp_move_starts_where_the_axis_stands(tmp_path: pathlib.Path) -> None:
    summary, samples, final = _run(tmp_path, "zoo_csp_position.toml", "start")
    assert summary["safe_stop_reason"] is None
    assert samples["reference"][0] == pytest.approx(START, abs=QUANTUM)  # the measured start
    assert samples["measurement"][0] == samples["reference"][0]  # the drive, not zeros
    assert final == pytest.approx(START + 10.0, abs=1e-2)
    # the stop sent no "zero" position: the drive is left with its last target, where it stands
    assert summary["left_target"] == pytest.approx(final, abs=QUANTUM)


def test_a_position_servo_moves_from_where_the_axis_stands(tmp_path: pathlib.Path) -> None:
    summary, samples, final = _run(
        tmp_path, "dc_servo_position.toml", "start", position_min=-100.0, position_max=100.0
    )
    assert summary["safe_stop_reason"] is None and summary["stop_confirmed"] is True
    assert samples["reference"][0] == pytest.approx(START, abs=QUANTUM)  # the measured start
    assert final == pytest.approx(START + 10.0, abs=0.05)


def test_an_absolute_csp_reference_away_from_the_shaft_is_refused(tmp_path: pathlib.Path) -> None:
    summary, samples, final = _run(tmp_path, "zoo_csp_position.toml", "zero")
    reason = summary["safe_stop_reason"]
    assert reason is not None and re.search(
        r"command 0 rad steps -4\.99\d* rad from the measured position", reason
    )
    assert summary["stop_confirmed"] is True
    assert "motor.command" not in samples or len(samples["t"]) == 0
    assert final == pytest.approx(START, abs=QUANTUM)  # no lurch to 0


def test_the_command_limit_of_csp_bounds_the_travel_from_the_start(tmp_path: pathlib.Path) -> None:
    """``[axis.limits] command`` of a CSP axis is the travel from the start: a move of 10 rad
    from 5 rad passes a limit of 12 rad; a limit of 8 rad stops it at 8 rad of travel."""
    summary, _, final = _run(tmp_path, "zoo_csp_position.toml", "start", command=8.0)
    reason = summary["safe_stop_reason"]
    assert reason is not None and re.search(
        r"from the start \(4\.99\d* rad\), beyond the limit 8 rad", reason
    )
    assert summary["stop_confirmed"] is True
    assert START + 7.0 < final < START + 8.5
    assert np.isfinite(final)
