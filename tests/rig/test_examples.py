"""Every example configuration runs briefly on its emulator; the Modbus example reaches its speed."""

from __future__ import annotations

import gc
import importlib.util
import pathlib

import pytest

from rig.config import load_config
from rig.run import run_config

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.toml")))
def test_example_runs_on_the_emulator(name: str, tmp_path: pathlib.Path) -> None:
    import dataclasses

    cfg = load_config(EXAMPLES / name)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path)))
    summary = run_config(cfg, emulate=True, duration=0.4)
    assert summary["safe_stop_reason"] is None
    assert summary["cycles"] > 0


def test_modbus_inverter_example_reaches_its_speed() -> None:
    spec = importlib.util.spec_from_file_location("modbus_example", EXAMPLES / "modbus_inverter_speed.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    result = module.main(["--speed", "50", "--seconds", "1.5"])
    assert result["speed"] == pytest.approx(50.0, abs=0.5)
    assert result["fault"] == 0
    gc.collect()
