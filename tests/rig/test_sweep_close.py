"""A sweep's close says nothing on stderr: the local workers close before their scheduler, and
what a closing worker logs about the connections its own close cuts (distributed's heartbeat
"Failed to communicate with scheduler" traceback) is dropped by ``ClosingCommNoise``."""

from __future__ import annotations

import logging
import pathlib
import subprocess
import sys
import textwrap

import pytest

from rig.sweep.cluster import ClosingCommNoise


def _record(error: BaseException | None) -> logging.LogRecord:
    """A record as ``logger.exception`` makes it inside ``except`` of ``error``."""
    log = logging.getLogger("distributed.worker")
    if error is None:
        return log.makeRecord(log.name, logging.ERROR, __file__, 1, "plain", (), None)
    try:
        raise error
    except BaseException:
        return log.makeRecord(log.name, logging.ERROR, __file__, 1, "failed", (), sys.exc_info())


def test_a_closing_workers_cut_connection_is_dropped_and_nothing_else() -> None:
    from distributed.comm.core import CommClosedError

    closing = ClosingCommNoise(lambda: True)
    running = ClosingCommNoise(lambda: False)
    cut = _record(CommClosedError("in <TCP (closed) ConnectionPool.heartbeat_worker>: Stream is closed"))
    assert not closing.filter(cut)
    assert running.filter(cut)  # a running worker that loses its scheduler says so
    assert closing.filter(_record(ValueError("a bug in a point")))
    assert closing.filter(_record(None))


RACE = """
import sys, time
import distributed.scheduler
distributed.scheduler.heartbeat_interval = lambda n: 0.002  # a heartbeat always in flight
from rig.sweep.cluster import close_client, open_client

if __name__ == "__main__":
    quick = sys.argv[1] == "quick"
    client, _ = open_client(workers=2)
    busy = [client.submit(time.sleep, 3, pure=False) for _ in range(2)] if quick else []
    time.sleep(1.0)  # the 2 ms interval reaches the workers with their first heartbeat answer
    close_client(client, quick=quick)
    print("closed", file=sys.stderr)
"""


@pytest.mark.slow
@pytest.mark.parametrize("how", ["quick", "normal"])
def test_closing_the_local_cluster_with_a_heartbeat_in_flight_prints_no_traceback(
    how: str, tmp_path: pathlib.Path
) -> None:
    """Heartbeats every 2 ms, so one is in flight when each worker closes: before the change 12 of
    20 closes (quick and normal alike) printed the worker's CommClosedError traceback."""
    script = tmp_path / "race.py"
    script.write_text(textwrap.dedent(RACE))
    for _ in range(3):
        done = subprocess.run(
            [sys.executable, str(script), how],
            check=False,
            capture_output=True,
            text=True,
            timeout=120,
            cwd=tmp_path,
        )
        assert done.returncode == 0 and done.stderr == "closed\n", done.stderr
