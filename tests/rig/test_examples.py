"""Every example configuration runs briefly on its emulator, through ``rig run``'s own path."""

from __future__ import annotations

import dataclasses
import pathlib

import pytest

from rig.config import load_config
from rig.host.session import run_config

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.toml")))
def test_example_runs_on_the_emulator(name: str, tmp_path: pathlib.Path) -> None:
    cfg = load_config(EXAMPLES / name)
    # in lock-step (an example in real time too): the default run does not depend on the load
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), time="lockstep"))
    summary = run_config(cfg, emulate=True, duration=0.4)
    assert summary["safe_stop_reason"] is None
    assert summary["cycles"] > 0


def test_no_example_is_a_script() -> None:
    """Every example is a configuration that ``rig run`` runs, not a program of its own."""
    assert not list(EXAMPLES.glob("*.py"))
