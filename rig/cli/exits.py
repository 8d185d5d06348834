"""rig's exit codes, the same for every command, and a run's: what each says and which a run's
summary gives (``exit_code``, ``not_written``)."""

from __future__ import annotations

from typing import Any

__all__ = [
    "EXIT_CODES",
    "EXIT_NOT_WRITTEN",
    "EXIT_STOPPED",
    "EXIT_UNCONFIRMED",
    "EXIT_UNTRUSTED",
    "EXIT_USAGE",
    "exit_code",
    "not_written",
]

EXIT_USAGE = 2
EXIT_STOPPED = 3
EXIT_UNCONFIRMED = 4  #: the drives' stop could not be confirmed: they may still be moving
EXIT_UNTRUSTED = 5  #: rig identify --strict: closed-loop data or a poor held-out fit
EXIT_NOT_WRITTEN = 6  #: a file of the run is missing or cut short (``files_not_written``)

#: every exit code of ``rig`` and what it says, the same for every command (``rig --help`` and
#: docs/cli.md show them; ``rig.cli.stopped`` makes the stop signals')
EXIT_CODES = {
    "0": "done",
    "1": "a failure (of the rig: communication, a device; or of the command)",
    "2": "a bad argument or configuration (one line on stderr naming it)",
    "3": "a safety stop (a limit, the watchdog, a device fault, ...), every drive confirmed at rest "
    "and disabled",
    "4": "a stop not confirmed, whatever began it (a safety stop or a signal): a drive may still be moving",
    "5": "--strict (rig identify, rig tune) and a warning",
    "6": "a file of the run not written whole (named on stderr)",
    "128+N": "stopped by signal N (130 Ctrl-C/SIGINT, 143 SIGTERM, 129 SIGHUP), every drive the command "
    "moved confirmed at rest; no result printed, one line on stderr saying what was kept",
    "141": "the reader of stdout left (rig ... | head)",
}


def exit_code(summary: dict[str, Any]) -> int:
    """A run's exit code: 0 done, 3 a safe stop, 6 a file of the run not written whole, 4 a stop
    not confirmed (before all: never like a clean one).

    Parameters
    ----------
    summary : dict[str, Any]
        The run's summary.

    Returns
    -------
    int
        0, 3, 4 or 6.
    """
    if summary.get("stop_confirmed") is False:
        return EXIT_UNCONFIRMED
    if summary.get("files_not_written"):
        return EXIT_NOT_WRITTEN
    return 0 if summary.get("safe_stop_reason") is None else EXIT_STOPPED


def not_written(summary: dict[str, Any], who: str) -> str | None:
    """One line naming the run's files not written whole and the samples not on disk (None: all
    written); where summary.json is among them, the summary printed is its only copy.

    Parameters
    ----------
    summary : dict[str, Any]
        The run's summary.
    who : str
        The command, named in the line.

    Returns
    -------
    str | None
        The line, or None.
    """
    files = summary.get("files_not_written") or []
    if not files:
        return None
    line = f"{who}: not written whole in {summary.get('run_dir')}: {', '.join(files)}"
    lost = summary.get("samples_not_written") or 0
    if lost:
        line += f"; {lost} samples not in samples.csv"
    if "summary.json" in files:
        line += "; the summary printed here is its only copy"
    return line + " (reasons: the summary's warnings)"
