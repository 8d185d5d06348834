"""A twin built on an EDS with objects taken out, and the host driving it on the same file: refused
in one line naming the file where the drive or its modes need an object (``drivers.maps.cia402_needs``),
else set up, enabled, run and disabled, or a toolkit error in one line; never another exception
(issue 33: an EDS without 0x6040/0x6041 gave ``rig emulate`` an SdoAbortedError traceback at boot).
"""

from __future__ import annotations

import dataclasses
import pathlib
import tempfile

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.cia402 import Cia402Axis
from drivers.errors import ConfigError, RigError
from drivers.maps.cia402_needs import EMULATED, needed
from drivers.maps.mode_names import MODE_NAMES
from plant_emulator.device_profile import load_profile, zoo
from plant_emulator.lockstep import LockstepBench
from tests.drivers.eds_edit import object_indices, without

PROFILE = load_profile(zoo()["epos4"])
TEXT = pathlib.Path(PROFILE.eds).read_text()
#: every object but the identity (load_od's own refusal) and the PDO parameters (their many
#: sub-entries make the cases slow without making them different)
CANDIDATES = [i for i in object_indices(TEXT) if i not in (0x1000, 0x1018) and not 0x1400 <= i < 0x1C00]
MODES = ("pp", "pv", "csp", "csv", "cst")  #: epos4's 0x6502 (and homing)
NEEDED = {*EMULATED, *(i for m in MODES for i in needed(MODE_NAMES[m])), 0x6098, 0x6502}
FUZZ = settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))


def _one_line(exc: BaseException, path: pathlib.Path | None = None) -> str:
    said = str(exc)
    assert "\n" not in said and "Traceback" not in said, said
    if path is not None:
        assert path.name in said, said
    return said


def _drive(path: pathlib.Path) -> None:
    """The twin of ``path``, driven on ``path`` in CSV: enable, a few cycles at zero, disable."""
    profile = dataclasses.replace(PROFILE, eds=path)
    try:
        bench = LockstepBench(profile.physics, device=profile)
    except ConfigError as exc:
        _one_line(exc, path)
        raise
    axis = Cia402Axis("drive", bench.host, profile.node_id, mode="csv", eds=str(path))
    axis.idle = bench.sync
    try:
        axis.setup()
        axis.enable()
        for _ in range(5):
            bench.sync()
            axis.feedback()
            axis.command(0.0)
        axis.disable()
    finally:
        axis.close()
        bench.close()


@pytest.mark.parametrize("lacks", [(0x6040, 0x6041), (0x6060,), (0x603F,), (0x1017,), (0x60FF,)])
def test_a_twin_lacking_what_it_needs_is_refused_naming_the_file(lacks: tuple[int, ...]) -> None:
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / "drive.eds"
        path.write_text(without(TEXT, *lacks))
        with pytest.raises(ConfigError) as err:
            _drive(path)
    said = _one_line(err.value, path)
    assert all(f"0x{i:04X} (" in said for i in lacks) and "which the emulated drive of" in said


@FUZZ
@given(st.sets(st.sampled_from(CANDIDATES), min_size=1, max_size=3))
def test_a_twin_lacking_objects_is_refused_or_runs(lacks: set[int]) -> None:
    with tempfile.TemporaryDirectory() as d:
        path = pathlib.Path(d) / "drive.eds"
        path.write_text(without(TEXT, *lacks))
        try:
            _drive(path)
        except ConfigError as exc:
            said = _one_line(exc, path)
            if lacks & NEEDED:
                assert "lacks 0x" in said or "has no 0x6502" in said, said
            return
        except RigError as exc:
            _one_line(exc)
            assert not lacks & NEEDED
            return
    assert not lacks & NEEDED  # what a twin or CSV needs was never missed
