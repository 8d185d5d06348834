"""A run's files under the cross-process faults of ``rig faults`` (``rig.faults.wire``): ``rig run``
on a small disk (``SMALL_FILES``) or without root's right to write past permission bits
(``NO_WRITE_OVERRIDE``, ``without_write_override``), and what reached its samples.csv."""

from __future__ import annotations

import contextlib
import ctypes
import os
from pathlib import Path

__all__ = ["NO_WRITE_OVERRIDE", "SMALL_FILES", "last_row_time", "rows_on_disk", "without_write_override"]

#: ``python -c SMALL_FILES LIMIT -m MODULE ARGS``: MODULE run with files limited to LIMIT bytes
#: (a write past it fails with EFBIG, SIGXFSZ ignored)
SMALL_FILES = """
import resource, runpy, signal, sys
limit = int(sys.argv[1])
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
sys.argv = sys.argv[3:]
runpy.run_module(sys.argv[0], run_name="__main__", alter_sys=True)
"""


_PR_CAPBSET_DROP = 24  #: prctl: drop a capability from the bounding set (linux/prctl.h)
_WRITE_OVERRIDES = (1, 2, 3)  #: CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER (linux/capability.h)


def without_write_override() -> None:
    """Before an exec: root's right to write past permission bits dropped from what the exec'd
    program gets, so a ``chmod 555`` stops it as it stops any user (nothing to drop for another
    user).

    Raises
    ------
    OSError
        If the capability cannot be dropped.
    """
    if os.geteuid() != 0:
        return
    libc = ctypes.CDLL(None, use_errno=True)
    for cap in _WRITE_OVERRIDES:
        if libc.prctl(_PR_CAPBSET_DROP, cap, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")


#: ``python -c NO_WRITE_OVERRIDE PROGRAM ARGS``: PROGRAM exec'd without root's write override
NO_WRITE_OVERRIDE = """
import os, sys
from rig.faults.run_files import without_write_override
without_write_override()
os.execv(sys.argv[1], sys.argv[1:])
"""


def rows_on_disk(run_dir: Path) -> int:
    """The rows of ``run_dir``'s samples.csv (0 where it cannot be read).

    Parameters
    ----------
    run_dir : Path
        A run's folder.

    Returns
    -------
    int
        Rows.
    """
    with contextlib.suppress(OSError), (run_dir / "samples.csv").open() as f:
        return sum(1 for _ in f) - 1
    return 0


def last_row_time(run_dir: Path) -> float:
    """The time [s] of the last complete row of ``run_dir``'s samples.csv.

    Parameters
    ----------
    run_dir : Path
        A run's folder.

    Returns
    -------
    float
        [s] (0 when there is none).
    """
    with contextlib.suppress(OSError), (run_dir / "samples.csv").open() as f:
        for line in reversed(f.read().splitlines()[1:]):
            with contextlib.suppress(ValueError):
                return float(line.split(",", 1)[0])
    return 0.0
