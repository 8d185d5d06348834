"""``rig run`` on every drive of the zoo: the same CSP position move, in each drive's own units and
PDOs, gives the toolkit's drive's trajectory to within the drive's unit quantisation."""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Any

import numpy as np
import pytest

from plant_emulator.device_profile import zoo
from rig.config import load_config, replace_axis
from rig.host.session import Session

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "zoo_csp_position.toml"
#: what a drive lacks and the axis configuration gives
UNITS = {"tmcm-1160": {"counts_per_rev": 51200}}


def _run(device: str, out: pathlib.Path) -> tuple[dict[str, Any], np.ndarray, float]:
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(
        cfg,
        run=dataclasses.replace(cfg.run, output=str(out), duration=1.5),
        emulator=dataclasses.replace(cfg.emulator, device=device),
    )
    if device in UNITS:
        cfg = replace_axis(cfg, "motor", units=UNITS[device])
    with Session(cfg, emulate=True) as session:
        session.start()
        summary = session.run()
        quantum = 1.0 / session.axes[0].units.position  # type: ignore[attr-defined]  # [rad]
        harmful = session.emulation.devices[0].harmful_writes  # type: ignore[union-attr]
    assert harmful == []
    data = np.genfromtxt(pathlib.Path(summary["run_dir"]) / "samples.csv", delimiter=",", names=True)
    return summary, data, quantum


@pytest.fixture(scope="module")
def toolkit(tmp_path_factory: pytest.TempPathFactory) -> np.ndarray:
    summary, data, _ = _run("drive-rig", tmp_path_factory.mktemp("toolkit"))
    assert summary["safe_stop_reason"] is None
    return data


@pytest.mark.parametrize("device", sorted(set(zoo()) - {"drive-rig"}))
def test_the_position_move_on_every_zoo_drive(
    device: str, toolkit: np.ndarray, tmp_path: pathlib.Path
) -> None:
    summary, data, quantum = _run(device, tmp_path)
    assert summary["safe_stop_reason"] is None and summary["stop_confirmed"] is True
    assert summary["cycles"] == len(toolkit)
    assert data["measurement"][-1] == pytest.approx(10.0, abs=5e-3)  # it arrives
    # the same trajectory: the difference is the drives' unit quantisation, not their behaviour
    tolerance = 3 * max(quantum, 2 * np.pi / 4096)
    assert np.max(np.abs(data["measurement"] - toolkit["measurement"])) < tolerance
