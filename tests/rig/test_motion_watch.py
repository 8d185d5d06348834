"""Motion checked against what was commanded (``rig.commission.motion_watch``): each check on
looks made up here, at and past its threshold, and the whole ``rig drive`` on the emulated
Nanotec twin with the units taken wrong the way an EDS-less first contact took them."""

from __future__ import annotations

import itertools
import json
import math

import pytest

from drivers.errors import SafetyStop
from rig.cli import main
from rig.commission.motion_watch import MotionWatch
from tests.patching import stand_in

T = 0.01  #: [s] between looks


def _looks(watch: MotionWatch, speeds: list[float], positions: list[float | None] | None = None) -> None:
    for k, v in enumerate(speeds):
        watch.see(k * T, v, None if positions is None else positions[k])


def _integral(speeds: list[float]) -> list[float | None]:
    """The positions [rad] the speeds [rad/s] make over looks ``T`` apart (trapezoid)."""
    out: list[float | None] = [0.0]
    for a, b in itertools.pairwise(speeds):
        out.append(float(out[-1] or 0.0) + 0.5 * (a + b) * T)
    return out


def test_a_jog_at_its_speed_and_limit_passes() -> None:
    w = MotionWatch("node 1: the jog", speed_limit=20.0, asked_speed=20.0, start=0.0, speed_quantum=0.1)
    speeds = [20.0 * min(1.0, k / 10) for k in range(100)]
    _looks(w, speeds, _integral(speeds))
    assert w.reached() == pytest.approx(20.0)


@pytest.mark.parametrize(
    ("asked", "speeds", "said"),
    [
        (20.0, [21.2] * 2, "faster than the limit 20 rad/s"),  # 1.05 x 20 + one unit = 21.1
        (5.0, [-0.72] * 3, "the wrong way"),  # 0.1 x 5 + two units + 0.01 = 0.71
        (5.0, [8.3] * 3, "1.66 times the 5 rad/s asked"),  # 1.5 x 5 + 0.71 = 8.21
    ],
)
def test_a_jog_off_its_request_stops(asked: float, speeds: list[float], said: str) -> None:
    w = MotionWatch("node 1: the jog", speed_limit=20.0, asked_speed=asked, speed_quantum=0.1)
    with pytest.raises(SafetyStop, match=said):
        _looks(w, speeds)


@pytest.mark.parametrize(
    ("asked", "speeds"),
    [
        (20.0, [21.0] * 5),
        (20.0, [21.2, 20.0] * 3),
        (5.0, [-0.7] * 5),
        (5.0, [8.2] * 5),
        (5.0, [8.3, 8.3, 5.0] * 3),
    ],
)
def test_within_the_tolerances_or_not_for_long_enough_a_jog_goes_on(
    asked: float, speeds: list[float]
) -> None:
    w = MotionWatch("node 1: the jog", speed_limit=20.0, asked_speed=asked, speed_quantum=0.1)
    _looks(w, speeds)


def test_position_and_speed_that_disagree_stop() -> None:
    """The Nanotec without its units: positions in 0.1 degree read as increments of 4000 a turn
    and speeds in rpm read the same way: the position runs 60 times the integrated speed."""
    w = MotionWatch("node 1: the jog", asked_speed=5.0, start=0.0, units="position 0x608F", accel=1000.0)
    speeds = [5.0] * 50
    positions: list[float | None] = [60.0 * 5.0 * k * T for k in range(50)]
    with pytest.raises(
        SafetyStop, match=r"moved .* rad while the speed 0x606C integrates to .*units from position"
    ):
        _looks(w, speeds, positions)


def test_position_and_speed_that_agree_within_a_lag_pass() -> None:
    w = MotionWatch("node 1: the jog", asked_speed=5.0, start=0.0, accel=1000.0)
    positions: list[float | None] = [5.0 * (k * T - 0.003) for k in range(200)]  # 3 ms behind the speed
    _looks(w, [5.0] * 200, positions)


@pytest.mark.parametrize("accel", [1000.0, math.inf])
def test_a_move_between_two_looks_at_rest_goes_on(accel: float) -> None:
    """rig drive --eds nanotec-c5e.eds move 2 --relative on the C5-E twin over socketcand: at 20
    rad/s and 1000 rad/s^2 (0x6083-0x6085) the 2 rad took about 0.12 s, between two looks 0.3 s
    apart that both saw the shaft at rest. The speed between looks is not their mean: at most
    1000 rad/s^2 it can reach 150 rad/s and come back, so 2 rad agrees; with no acceleration
    known nothing bounds it. It stopped as 'the drive's units are not those drive-rig took'."""
    w = MotionWatch("node 1: the move", start=10.52, target=12.52, position_quantum=1.7e-3, accel=accel)
    w.see(0.0, 0.0, 10.52)
    w.see(0.3, 0.0, 12.521)
    w.see(0.31, 0.0, 12.521)


@pytest.mark.parametrize(
    ("positions", "said"),
    [
        ([0.0, -0.2, -0.5], "moving away from the target"),
        ([0.0, 0.5, 1.0, 1.12], "past the target"),
    ],
)
def test_a_move_the_wrong_way_or_past_its_target_stops(positions: list[float], said: str) -> None:
    w = MotionWatch("node 1: the move", start=0.0, target=1.0, position_quantum=1e-3)
    with pytest.raises(SafetyStop, match=said):
        _looks(w, _speeds(positions), list(positions))


def _speeds(positions: list[float]) -> list[float]:
    """Speeds [rad/s] whose trapezoid integral over looks ``T`` apart gives ``positions``."""
    out = [0.0]
    for a, b in itertools.pairwise(positions):
        out.append(2.0 * (b - a) / T - out[-1])
    return out


def test_a_move_within_its_window_passes() -> None:
    w = MotionWatch("node 1: the move", start=0.0, target=1.0, position_quantum=1e-3)
    positions = [0.0, 0.5, 1.09, 1.0]
    _looks(w, _speeds(positions), list(positions))


def _json(capsys: pytest.CaptureFixture[str], code: int, *argv: str) -> dict:  # type: ignore[type-arg]
    assert main(["drive", "--emulate", "nanotec-c5e", "--json", *argv]) == code
    return json.loads(capsys.readouterr().out)  # type: ignore[no-any-return]


def test_the_nanotec_jog_moves_as_asked(capsys: pytest.CaptureFixture[str]) -> None:
    r = _json(capsys, 0, "jog", "5", "--for", "1")
    assert r["result"] == "done" and r["reached_rad_s"] == pytest.approx(5.0, rel=0.1)
    assert r["asked_rad_s"] == 5.0


def test_the_nanotec_jog_with_its_units_taken_wrong_is_stopped(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """As the toolkit met it without its EDS before: its unit objects (0x60A8, 0x60A9, 0x6091, 0x6092)
    unread, its 0x608F (4000) taken for both units: 5 rad/s became 3183 rpm. The watch stops it
    within a few looks of the start."""
    import drivers.identity

    read = drivers.identity.read_standard

    def blind(upload, index, subindex=0):  # type: ignore[no-untyped-def]
        return None if index in (0x60A8, 0x60A9, 0x6091, 0x6092) else read(upload, index, subindex)

    looks: list[tuple[float, float, float | None]] = []

    class Counted(MotionWatch):
        def see(self, t: float, speed: float, position: float | None) -> None:
            looks.append((t, speed, position))
            super().see(t, speed, position)

    monkeypatch.setattr("drivers.cia402_discovery.read_standard", blind)
    stand_in(monkeypatch, "rig.commission.motion_watch.MotionWatch", Counted)
    r = _json(capsys, 3, "jog", "5", "--for", "1")
    assert r["result"].startswith("stopped: node 1: the jog: ")
    assert "units" in r["result"] or "faster than the limit 20 rad/s" in r["result"]
    assert r["stop_confirmed"] is True and r["state"] == "SWITCH ON DISABLED"
    assert looks and looks[-1][0] <= 0.05  # stopped within 50 ms of the jog's 1 s
    assert math.isfinite(r["position_rad"])
