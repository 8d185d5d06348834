"""Drives of several axes on one node (``drivers.maps.logical``): two ``[[axis]]`` tables of one
node run the dual-axis twin's two motors independently, each axis read and commanded by its own
objects (axis 2's 0x800 higher) through the node's PDOs shared between them; ``rig drive --axis 2``
commissions the second axis. Lock-step, in this process."""

from __future__ import annotations

import dataclasses
import json
import pathlib
from collections.abc import Iterator

import numpy as np
import pytest

from drivers.cia402 import Cia402Axis
from drivers.errors import ConfigError
from drivers.maps import cia
from plant_emulator.device_profile import device_profile
from plant_emulator.lockstep import LockstepBench
from rig.cli import main
from rig.config import load_config
from rig.host.session import Session

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dual_axis_speed.toml"
PROFILE = device_profile("dual-axis")
EDS = str(PROFILE.eds)


def _axis_of(index: int) -> int:
    return 1 + (index - 0x6000) // 0x800 if 0x6000 <= index < 0xA000 else 0


def test_two_axes_of_one_node_run_independently_by_their_own_objects(tmp_path: pathlib.Path) -> None:
    """``left`` (axis 1) follows +10 rad/s, ``right`` (axis 2) its profile of -20 rad/s, in one
    cycle: the node's PDOs carry both (RPDO1 and TPDO1-2 axis 1's objects, RPDO3 and TPDO3-4
    axis 2's, as the host mapped them), each axis's samples are its own motor's."""
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), duration=0.8))
    with Session(cfg, emulate=True) as session:
        session.start()
        drive = session.transport.emulation.devices[0]  # type: ignore[union-attr]
        mapped = {
            f"{'R' if receive else 'T'}PDO{p.number + 1}": {_axis_of(index) for index, _, _ in p.mapping}
            for receive, pdos in ((True, drive.pdos.tables.rpdos), (False, drive.pdos.tables.tpdos))
            for p in pdos
            if p.valid and p.mapping
        }
        assert mapped == {"RPDO1": {1}, "RPDO3": {2}, "TPDO1": {1}, "TPDO2": {1}, "TPDO3": {2}, "TPDO4": {2}}
        left, right = session.axes
        assert [e.index for e in right.data.rpdo.entries] == [0x6040, 0x60FF]  # type: ignore[attr-defined]
        assert "RPDO3 0x401 (0x6840 0x68FF)" in [f for f, _ in right.cycle_frames()]  # type: ignore[attr-defined]
        assert "RPDO1 0x201 (0x6040 0x60FF)" in [f for f, _ in left.cycle_frames()]  # type: ignore[attr-defined]
        summary = session.run()
    assert summary["safe_stop_reason"] is None and summary["stop_confirmed"] is True
    data = np.genfromtxt(
        pathlib.Path(summary["run_dir"]) / "samples.csv", delimiter=",", names=True, deletechars=""
    )
    end = data["t"] >= 0.6
    assert np.mean(data["left.velocity"][end]) == pytest.approx(10.0, abs=0.05)
    assert np.mean(data["right.velocity"][end]) == pytest.approx(-20.0, abs=0.05)
    assert np.all(data["right.command"][data["t"] >= 0.1] == -20.0)
    # the positions each integrate their own speed (from rest, in opposite directions)
    assert data["left.position"][-1] > 4.0 and data["right.position"][-1] < -8.0


def _cfg(tmp_path: pathlib.Path, second: str) -> pathlib.Path:
    text = EXAMPLE.read_text().replace("axis = 2                # the same node's second axis", second)
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("second", "said"),
    [
        ("axis = 1", "two [[axis]] tables are axis 1 of node_id 1"),
        (f'axis = 3\neds = "{EDS}"', "describes a drive of 2 axes (no 0x7041, axis 3's statusword)"),
        ("axis = 9", "axis"),
    ],
)
def test_an_axis_the_drive_has_not_is_refused_at_load(tmp_path: pathlib.Path, second: str, said: str) -> None:
    with pytest.raises(ConfigError, match=said.replace("[", r"\[").replace("(", r"\(").replace(")", r"\)")):
        load_config(_cfg(tmp_path, second))


def test_an_encoder_still_has_a_node_of_its_own(tmp_path: pathlib.Path) -> None:
    text = EXAMPLE.read_text() + '\n[[axis]]\nname = "enc"\nkind = "cia406"\nnode_id = 1\n'
    path = tmp_path / "rig.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match="two CANopen axes have node_id 1"):
        load_config(path)


def test_rig_drive_axis_2_status_and_jog(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["drive", "--emulate", "dual-axis", "--axis", "2", "--json", "status"]) == 0
    status = json.loads(capsys.readouterr().out)
    assert status["node"] == 1 and status["axis"] == 2 and status["state"] == "SWITCH ON DISABLED"
    assert status["pdo_mapping"]["TPDO3"]["entries"] == ["0x6841:00/16", "0x6864:00/32"]
    assert main(["drive", "--emulate", "dual-axis", "--axis", "2", "--json", "sdo", "read", "0x6061"]) == 0
    assert json.loads(capsys.readouterr().out)["object"] == "0x6861:00"
    assert main(["drive", "--emulate", "dual-axis", "--axis", "2", "--json", "jog", "5", "--for", "0.5"]) == 0
    jog = json.loads(capsys.readouterr().out)
    assert jog["reached_rad_s"] == pytest.approx(5.0, abs=0.05) and jog["stop_confirmed"] is True
    assert jog["position_rad"] > 2.0  # axis 2's own position 0x6864
    assert main(["drive", "--emulate", "dual-axis", "--axis", "3", "status"]) == 2
    assert "no 0x7041, axis 3's statusword" in capsys.readouterr().err


@pytest.fixture
def bench() -> Iterator[LockstepBench]:
    b = LockstepBench(PROFILE.physics, device=PROFILE)
    yield b
    b.close()


def _axis(b: LockstepBench, axis: int, **kw: object) -> Cia402Axis:
    a = Cia402Axis(f"a{axis}", b.host, 1, period=b.period, axis=axis, **kw)  # type: ignore[arg-type]
    a.idle = b.sync
    return a


def test_the_node_s_watch_of_the_host_is_lifted_by_the_last_axis_disabled(bench: LockstepBench) -> None:
    """0x1016 is the node's: axis 1 disabled while axis 2 runs leaves the host watched."""
    axes = [_axis(bench, n, mode="csv", eds=EDS, host=(127, 0.3)) for n in (1, 2)]
    for a in axes:
        a.setup()
    for a in axes:
        a.enable(timeout=30.0)
    entry = axes[0].sdo_read(cia.CONSUMER_HEARTBEAT, 1)
    assert entry == 127 << 16 | 300
    axes[0].quick_stop()
    for _ in range(50):
        bench.sync()
    axes[0].disable()
    assert axes[0].sdo_read(cia.CONSUMER_HEARTBEAT, 1) == entry  # axis 2 is still enabled
    axes[1].disable()
    assert axes[1].sdo_read(cia.CONSUMER_HEARTBEAT, 1) == 0
    for a in axes:
        a.close()


def test_axis_2_of_a_drive_met_without_its_eds(bench: LockstepBench) -> None:
    """No EDS given: the toolkit's generic dictionary, axis 2's objects as CiA 402 lays them out
    (0x800 higher); identity and units read from the device, the motor run in CSV by axis 2's
    own PDOs (the node's second half)."""
    a = _axis(bench, 2, mode="csv")
    a.setup()
    assert a.where == "node 1 axis 2"
    assert {f.split()[0] for f, _ in a.cycle_frames()} == {"TPDO3", "TPDO4", "RPDO3"}
    a.enable(timeout=30.0)
    for _ in range(1500):
        a.command(7.0)
        bench.sync()
    assert a.feedback().velocity == pytest.approx(7.0, abs=0.05)
    assert bench.devices[0].others[0].axis.velocity == pytest.approx(7.0, abs=0.05)  # type: ignore[attr-defined]
    assert bench.devices[0].axis.velocity == 0.0  # axis 1's motor
    a.close()


def test_an_rpdo_of_the_drive_s_own_that_writes_the_other_axis_too_is_refused(bench: LockstepBench) -> None:
    """pdo = "device": axis 1's target RPDO also carrying axis 2's controlword is refused for cyclic use,
    naming it (the host would write axis 2's controlword with axis 1's frame every cycle)."""
    node = _axis(bench, 1, mode="csp", eds=EDS)
    node.sdo_write(0x1400, 1, 0x80000201)
    node.sdo_write(0x1600, 0, 0)
    node.sdo_write(0x1600, 3, cia.map_entry(0x6840, 0, 16))
    node.sdo_write(0x1600, 0, 3)
    node.close()
    a = _axis(bench, 1, mode="csp", eds=EDS, pdo="device")
    with pytest.raises(ConfigError, match=r"also carries 0x6840:00.*an object of the device.s axis 2"):
        a.setup()
    a.close()
