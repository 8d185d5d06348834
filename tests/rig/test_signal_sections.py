"""A stop signal never falls between a cycle's row and its count: inside ``StopRequests.held``
it waits for the section's end (the host-sigterm scenario once counted one row more on disk
than cycles run)."""

from __future__ import annotations

import os
import signal

import pytest

from rig.host.signals import StopRequested, StopRequests, forget


@pytest.fixture
def requests():  # type: ignore[no-untyped-def]
    forget()  # each test's signal is the process's first
    # handlers not ignored, whatever started the tests (under nohup SIGHUP is ignored, and a
    # session leaves an ignored signal ignored: tests/rig/test_stop_signals.py)
    before = {sig: signal.signal(sig, signal.SIG_DFL) for sig in (signal.SIGHUP, signal.SIGTERM)}
    r = StopRequests()
    r.install()
    yield r
    r.restore()
    for sig, handler in before.items():
        signal.signal(sig, handler)


def test_a_signal_in_the_section_raises_at_its_end(requests: StopRequests) -> None:
    steps = []
    with pytest.raises(StopRequested, match="SIGTERM"):
        with requests.held:
            os.kill(os.getpid(), signal.SIGTERM)  # delivered here, at the next bytecode
            steps.append("row written")
            steps.append("counted")
    assert steps == ["row written", "counted"]


def test_outside_the_section_it_raises_at_once(requests: StopRequests) -> None:
    with pytest.raises(StopRequested, match="SIGHUP"):
        os.kill(os.getpid(), signal.SIGHUP)
        raise AssertionError("not reached")


def test_an_error_in_the_section_is_not_replaced(requests: StopRequests) -> None:
    with pytest.raises(OSError, match="disk full"):
        with requests.held:
            os.kill(os.getpid(), signal.SIGTERM)
            raise OSError("disk full")
    with requests.held:  # the request was taken: no second stop later
        pass
