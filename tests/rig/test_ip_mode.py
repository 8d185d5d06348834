"""Interpolated position mode from the host (``mode = "ip"``): one position a SYNC in 0x60C1:01 with
controlword bit 4 (enable ip mode), linear interpolation (0x60C0 = 0) over the SYNC period (0x60C2)
and the drive's buffer emptied at the enable; lock-step in this process, on the dual-axis twin
(``examples/dual_axis_ip.toml``: axis 1 in ip, axis 2 in CSV on the same node)."""

from __future__ import annotations

import dataclasses
import json
import pathlib
import re
from typing import Any

import numpy as np
import pytest

from drivers.errors import ConfigError
from drivers.maps import cia
from drivers.maps.cia import PowerState
from rig.config import load_config, replace_axis
from rig.host.session import Session

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
EXAMPLE = EXAMPLES / "dual_axis_ip.toml"
TWIN_PROFILE = EXAMPLES.parent / "plant_emulator" / "devices" / "dual-axis.toml"
TWIN_EDS = TWIN_PROFILE.with_suffix(".eds")


def _run(out: pathlib.Path, mode: str) -> tuple[dict[str, Any], np.ndarray, dict[str, Any]]:
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(out), duration=0.8))
    cfg = replace_axis(cfg, "arm", mode=mode)
    seen: dict[str, Any] = {}
    with Session(cfg, emulate=True) as session:
        session.start()
        arm = session.axes[0]
        drive: Any = session.transport.emulation.devices[0]  # type: ignore[union-attr]
        if mode == "ip":
            seen["0x60C2"] = arm.sdo_read(cia.INTERPOLATION_PERIOD, 1) * 10.0 ** arm.sdo_read(  # type: ignore[attr-defined]
                cia.INTERPOLATION_PERIOD, 2
            )
            seen["0x60C0"] = arm.sdo_read(cia.INTERPOLATION_SUBMODE)  # type: ignore[attr-defined]
            seen["rpdo"] = [e.index for e in arm.data.rpdo.entries]  # type: ignore[attr-defined]
        summary = session.run()
        seen["underflows"], seen["refused"] = drive.profiles.ip.underflows, drive.profiles.ip.refused
    data = np.genfromtxt(
        pathlib.Path(summary["run_dir"]) / "samples.csv", delimiter=",", names=True, deletechars=""
    )
    return summary, data, seen


def test_a_position_profile_in_ip_is_followed_as_in_csp(tmp_path: pathlib.Path) -> None:
    """The smooth move of 5 rad arrives; the drive took every record as it came (no underflow, no
    record refused), so the shaft moves as the same profile streamed in CSP moves it (one period
    of delay both: a synchronous RPDO's record enters the buffer at its SYNC and is taken there);
    axis 2 turns at its own 10 rad/s meanwhile."""
    ip, data, seen = _run(tmp_path / "ip", "ip")
    assert ip["safe_stop_reason"] is None and ip["stop_confirmed"] is True
    assert seen["0x60C2"] == pytest.approx(0.0004) and seen["0x60C0"] == 0
    assert seen["rpdo"] == [cia.CONTROLWORD, cia.INTERPOLATION_DATA]
    assert seen["underflows"] == 0 and seen["refused"] == 0
    assert data["measurement"][-1] == pytest.approx(5.0, abs=0.01)
    assert np.mean(data["feeder.velocity"][data["t"] >= 0.6]) == pytest.approx(10.0, abs=0.05)
    csp, reference, _ = _run(tmp_path / "csp", "csp")
    assert csp["cycles"] == ip["cycles"]
    assert np.max(np.abs(data["measurement"] - reference["measurement"])) < 1e-9  # identical: 0.0 here


def test_ip_on_a_drive_that_has_it_not_is_refused_before_anything_is_written(tmp_path: pathlib.Path) -> None:
    cfg = load_config(EXAMPLES / "zoo_csp_position.toml")  # the EPOS4 twin: no ip in its 0x6502
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path)))
    cfg = replace_axis(cfg, "motor", mode="ip")
    with Session(cfg, emulate=True) as session, pytest.raises(ConfigError, match=r"mode ip is not in 0x6502"):
        session.start()


def test_a_drive_whose_ip_buffer_is_a_ring_it_cannot_leave_is_refused_before_the_enable(
    tmp_path: pathlib.Path,
) -> None:
    """The host sends one record a SYNC into a FIFO: a drive whose EDS declares its buffer
    organisation 0x60C4:03 read-only and a ring (1) is refused, naming the object and what to do,
    and its axis is never enabled."""
    eds = tmp_path / "dual-axis.eds"
    text, n = re.subn(
        r"(\[60C4sub3\][^[]*?AccessType=)rw([^[]*?DefaultValue=)0", r"\g<1>ro\g<2>1", TWIN_EDS.read_text()
    )
    assert n == 1
    eds.write_text(text)
    profile = tmp_path / "dual-axis.toml"
    profile.write_text(TWIN_PROFILE.read_text())
    text = EXAMPLE.read_text().replace('device = "dual-axis"', f"device = {json.dumps(str(profile))}")
    text = text.replace('"../plant_emulator/devices/dual-axis.eds"', json.dumps(str(eds)))  # the host's too
    config = tmp_path / "rig.toml"
    config.write_text(text.replace('output = "runs"', f"output = {json.dumps(str(tmp_path))}"))
    cfg = load_config(config)
    with Session(cfg, emulate=True) as session:
        with pytest.raises(ConfigError, match=r"0x60C4:03.*holds 1; the ip buffer a FIFO wanted 0.*csp"):
            session.start()
        drive: Any = session.transport.emulation.devices[0]  # type: ignore[union-attr]
        assert drive.sm.state is not PowerState.OPERATION_ENABLED
