"""``rig bench loop``'s lock-step runs end clean: no drive fault, the stop confirmed.

The servo's load is the emulator's own (``rig demo``'s pulse from 1.5 to 3 s), an active load
the host's stop does not end. Cut at 2 s, it turned the disabled motor up to 0x6080 (6000 rpm)
after each servo run: three EMCY 0x8400 per ``rig bench loop``, its figures printed all the same.
Lock-step: deterministic; no figure is asserted.
"""

from __future__ import annotations

import pathlib

import pytest

from rig.bench.loop import lockstep_rate, lockstep_runs
from rig.papers.demo import demo_config


def test_a_run_cut_before_its_emulated_load_ends_is_not_a_figure(tmp_path: pathlib.Path) -> None:
    with pytest.raises(RuntimeError, match="demo-dc-servo did not end clean: motor: node 1: EMCY 0x8400"):
        lockstep_rate(demo_config(str(tmp_path)), 2.0)


def test_the_bench_lockstep_runs_end_at_rest_without_a_fault(tmp_path: pathlib.Path) -> None:
    runs = lockstep_runs(str(tmp_path), 2.0)
    assert [cfg.run.name for cfg, _ in runs] == ["demo-dc-servo", "dyno"]
    for cfg, seconds in runs:
        assert lockstep_rate(cfg, seconds) > 0.0
