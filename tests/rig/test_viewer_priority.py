"""A viewer's thread beside a real-time loop (``rig.host.viewer_priority``): at the lowest
SCHED_FIFO priority, off the loop's CPU, while the loop is at real-time priority; given back with
the loop's grant; left alone where the loop is not at real-time priority."""

from __future__ import annotations

import dataclasses
import os
import pathlib
import threading
from collections.abc import Sequence

import pytest

from rig.config import load_config
from rig.host.realtime import Grant, RealtimeRequest
from rig.host.session import run_config
from rig.host.viewer_priority import VIEWER_PRIORITY, raise_viewer
from rig.live import Channel, LiveView

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "dc_servo_position.toml"

pytestmark = pytest.mark.skipif(
    not hasattr(os, "sched_setscheduler") or os.geteuid() != 0, reason="SCHED_FIFO granted (root)"
)


def test_the_viewer_is_raised_off_the_loop_s_cpu_and_given_back() -> None:
    stop = threading.Event()
    viewer = threading.Thread(target=stop.wait, name="rig-live", daemon=True)
    viewer.start()
    assert viewer.native_id is not None
    tid, cpus = viewer.native_id, os.sched_getaffinity(0)
    loop = max(cpus)
    try:
        assert not raise_viewer(Grant(RealtimeRequest(), priority=0, cpu=loop), viewer)  # loop not real-time
        assert os.sched_getscheduler(tid) == os.SCHED_OTHER and os.sched_getaffinity(tid) == cpus
        grant = Grant(RealtimeRequest(), priority=50, cpu=loop)
        assert raise_viewer(grant, viewer)
        assert os.sched_getscheduler(tid) == os.SCHED_FIFO
        assert os.sched_getparam(tid).sched_priority == VIEWER_PRIORITY == 1
        assert os.sched_getaffinity(tid) == (cpus - {loop} or cpus)
        grant.release()
        assert os.sched_getscheduler(tid) == os.SCHED_OTHER and os.sched_getaffinity(tid) == cpus
    finally:
        stop.set()
        viewer.join()
    assert not raise_viewer(Grant(RealtimeRequest(), priority=50, cpu=loop), viewer)  # ended


class Policies:
    """A backend that notes its thread's scheduling policy at each draw."""

    def __init__(self) -> None:
        self.seen: list[int] = []
        self.raised = threading.Event()

    def open(self, channels: Sequence[Channel], title: str) -> None:
        pass

    def draw(self, rows: Sequence[Sequence[float]], final: bool = False) -> None:
        self.seen.append(os.sched_getscheduler(0))
        if self.seen[-1] == os.SCHED_FIFO:
            self.raised.set()

    def close(self) -> None:
        pass


def test_a_realtime_run_raises_its_live_view_for_the_run_only(tmp_path: pathlib.Path) -> None:
    """``Session.run`` raises the live view's thread with the loop and gives it back at the end:
    the loop's first progress waits until the viewer has drawn at SCHED_FIFO (fails without
    ``raise_viewer`` in ``Session.run``: the wait runs out)."""
    cfg = load_config(EXAMPLE)
    cfg = dataclasses.replace(cfg, run=dataclasses.replace(cfg.run, output=str(tmp_path), time="realtime"))
    backend = Policies()
    live = LiveView(backend, rate=1000.0)
    waited: list[bool] = []

    def progress(k: int, n: int) -> None:
        if not waited:
            waited.append(backend.raised.wait(10.0))

    run_config(cfg, emulate=True, duration=0.05, progress=progress, live=live)
    assert waited == [True]
    assert backend.seen[0] == os.SCHED_OTHER  # before the loop's request
    assert backend.seen[-1] == os.SCHED_OTHER  # the last draw, after the loop's grant was given back
