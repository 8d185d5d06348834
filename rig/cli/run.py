"""``rig run``: a configured rig (axes and a law) over the wire, with safety and the recorder."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rig.cli.common import (
    UsageError,
    add_json,
    add_params,
    exit_code,
    finite,
    not_written,
    print_json,
)
from rig.cli.progress import Progress
from rig.host.signals import StopRequested
from rig.report.summary import summary_lines

if TYPE_CHECKING:
    from rig.live import LiveView
    from rig.live.backend import Live

__all__ = ["LIVE_MODES", "add_parser", "open_view", "print_summary"]

LIVE_MODES = ("auto", "terminal", "window")  #: --live's choices (``rig.live.MODES``)
CONFIGURED = ""  #: ``--emulate`` without a name: the configuration's own [emulator]


def add_parser(sub: Any) -> None:
    """``rig run``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    run = sub.add_parser(
        "run",
        help="run a configured control law over the wire (see examples/)",
        description="Run the rig of a configuration file (docs/configuration.md): every axis set up and "
        "enabled, the law on one SYNC per period, limits, watchdog and supervision per axis, the one safe "
        "stop, a run directory. Exit code 3 after a safe stop, 4 when a drive's stop is not confirmed; "
        "Ctrl-C or SIGTERM: that stop, then 130 or 143, the summary only in the run's summary.json.",
    )
    run.add_argument("--config", required=True, metavar="FILE", help="the rig configuration (TOML)")
    run.add_argument(
        "--emulate",
        nargs="?",
        const=CONFIGURED,
        metavar="NAME",
        help="run the emulator in this process: the configuration's [emulator], or NAME in its place (a "
        "preset or a zoo twin, rig emulate --list; [emulator.params] kept)",
    )
    run.add_argument("--duration", type=finite, help="override [run] duration [s]")
    run.add_argument(
        "--reset-fault",
        action="store_true",
        help="reset a CiA 402 drive found in FAULT (as reset_fault = true on every such axis)",
    )
    run.add_argument(
        "--no-limits",
        action="store_true",
        help="run an axis the law or a profile commands even though [axis.limits] gives it no command, "
        "speed, position or current limit (refused without this option); the watchdog and the "
        "drive's own limits still apply",
    )
    _add_display(run)
    add_json(run, "print the summary as one JSON object")
    add_params(
        run,
        "inject a fault (overrides [faults]; names as in docs/faults.md); bus faults need --emulate",
        flag="--fault",
    )
    run.set_defaults(handler=execute)


def _add_display(run: Any) -> None:
    """``--live`` and ``--view``: the run shown as it goes."""
    run.add_argument(
        "--live",
        nargs="?",
        const="auto",
        choices=LIVE_MODES,
        metavar="{terminal,window}",
        help="show each axis's reference, measurement and command as they arrive, a few times a second "
        "from another thread: in a matplotlib window (closed at the end of the run) where matplotlib "
        "and a display are there, else as a strip on stderr; --live=terminal or --live=window chooses "
        "(a window that cannot open: exit 2 before anything moves). Example: rig run --config "
        "examples/dyno_speed_load.toml --emulate --live=terminal",
    )
    run.add_argument(
        "--view",
        nargs="?",
        const="127.0.0.1:8050",
        metavar="[HOST:]PORT",
        help="serve the view (rig view) beside the run: a live scope of each axis's reference, "
        "measurement, command, state and faults at 25 updates/s, fed off the control thread, and the "
        "runs of [run] output; 127.0.0.1:8050 unless given (another host prints a token every request "
        "needs). Read-only. Needs the view extra: pip install 'drive-rig[view]'",
    )


def print_summary(summary: dict[str, Any]) -> None:
    """The summary for a person (``rig.report.summary.summary_lines``).

    Parameters
    ----------
    summary : dict[str, Any]
        The run's summary.
    """
    print("\n".join(summary_lines(summary)))


def open_view(mode: str | None, who: str) -> LiveView | None:
    """The live view of ``--live`` (None without it); UsageError when it cannot be shown.

    Parameters
    ----------
    mode : str | None
        ``--live`` (None: no live view).
    who : str
        The command, named in the error.

    Returns
    -------
    LiveView | None
        The live view, or None.

    Raises
    ------
    UsageError
        If it cannot be shown.
    """
    if mode is None:
        return None
    from rig.live import LiveUnavailable, open_live

    try:
        return open_live(mode)
    except LiveUnavailable as exc:
        raise UsageError(f"{who}: --live={mode}: {exc}") from None


def _strip(live: Live | None) -> bool:
    """True when ``live`` draws the terminal strip (on stderr, as the progress line would)."""
    from rig.live import LiveView
    from rig.live.terminal import TerminalStrip

    return isinstance(live, LiveView) and isinstance(live.backend, TerminalStrip)


def execute(args: argparse.Namespace) -> int:
    from plant_emulator.faults import FAULT_NAMES
    from rig.config import Override
    from rig.config.checks import require_limits
    from rig.config.params import parse_items
    from rig.host.session import run_config

    if args.duration is not None and args.duration <= 0.0:
        raise UsageError(f"rig run: argument --duration: must be > 0 s, got {args.duration:g}")
    faults = parse_items(args.fault, "rig run: --fault")
    bus_faults = sorted(set(faults) & set(FAULT_NAMES))
    if bus_faults and args.emulate is None:
        raise UsageError(
            f"rig run: --fault {', '.join(bus_faults)} needs --emulate (the emulator injects it)"
        )
    # the faults are checked with the file, in the same pass, named by the option
    overrides = [Override("faults", faults, "rig run: --fault")] if faults else []
    cfg = _configured(args.config, args.emulate, overrides)
    if not args.no_limits:
        require_limits(cfg)
    if args.reset_fault:
        axes = tuple(dataclasses.replace(a, reset_fault=True) if a.kind == "cia402" else a for a in cfg.axes)
        cfg = dataclasses.replace(cfg, axes=axes)
    if args.live is not None and args.view is not None:
        raise UsageError("rig run: --live and --view: give one (the view's page shows what --live shows)")
    live: Live | None = open_view(args.live, "rig run")
    started, view = None, None
    if args.view is not None:
        from rig.cli.view import start_beside

        live, started, view = start_beside(args.view, cfg)
    bar = Progress("rig run", 0, "cycles", json=args.json or _strip(live))  # the strip shows the time
    summary: dict[str, Any] = {}
    try:
        summary = run_config(
            cfg,
            emulate=args.emulate is not None,
            duration=args.duration,
            progress=bar.cycles,
            live=live,
            started=started,
        )
    except StopRequested as exc:  # a stop signal: no result printed, but the view shows how it ended
        summary = _kept_summary(exc.kept)
        raise
    finally:
        bar.close()
        if live is not None:
            live.stop()
        if view is not None:
            view.finish(summary)
    if args.json:
        print_json(summary)
    else:
        print_summary(summary)
    if line := not_written(summary, "rig run"):
        print(line, file=sys.stderr)
    return exit_code(summary)


def _kept_summary(run_dir: str | None) -> dict[str, Any]:
    """The summary.json a run stopped by a signal left in ``run_dir`` ({} where there is none)."""
    try:
        found = json.loads((Path(run_dir) / "summary.json").read_text()) if run_dir else {}
    except (OSError, ValueError):
        return {}
    return found if isinstance(found, dict) else {}


def _configured(path: str, name: str | None, overrides: list[Any]) -> Any:
    """The configuration at ``path``, with ``--emulate NAME``'s preset or twin as its [emulator]
    (None, ``CONFIGURED``: its own), checked as the file would be."""
    from drivers.files import read_toml
    from rig.cli.common import emulated
    from rig.config import load_config
    from rig.config.load import rig_config

    if name is None or name == CONFIGURED:
        return load_config(path, overrides)
    kind, _ = emulated(name, "rig run")
    doc = read_toml(path, what="rig configuration")
    given = doc.get("emulator")
    table = {
        k: v for k, v in (given if isinstance(given, dict) else {}).items() if k not in ("preset", "device")
    }
    doc["emulator"] = {kind: name, **table}
    return rig_config(doc, path, overrides)  # its folder: where its relative paths are
