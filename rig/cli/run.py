"""``rig run``: a configured rig (axes and a law) over the wire, with safety and the recorder."""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from rig.cli.common import UsageError, add_json, add_params, exit_code, finite, params_of, print_json
from rig.cli.progress import Progress
from rig.report import summary_lines

__all__ = ["add_parser", "print_summary"]


def add_parser(sub: Any) -> None:
    run = sub.add_parser(
        "run",
        help="run a configured control law over the wire (see examples/)",
        description="Run the rig of a configuration file (rig/config.py documents every key): every "
        "axis set up and enabled, the law on one SYNC per period, limits, watchdog and supervision per "
        "axis, the one safe stop, and a run directory. Exit code 3 after a safe stop, 4 when a "
        "drive's stop could not be confirmed.",
    )
    run.add_argument("--config", required=True, metavar="FILE", help="the rig configuration (TOML)")
    run.add_argument("--emulate", action="store_true", help="run the configured emulator in this process")
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
    add_json(run, "print the summary as one JSON object")
    add_params(
        run,
        "inject a fault (overrides [faults]); names as in [faults] (rig/config.py); the bus faults "
        "need --emulate",
        flag="--fault",
    )
    run.set_defaults(handler=execute)


def print_summary(summary: dict[str, Any]) -> None:
    """The summary for a person (``rig.report.summary_lines``)."""
    print("\n".join(summary_lines(summary)))


def execute(args: argparse.Namespace) -> int:
    from drivers.errors import ConfigError
    from rig.config import FaultsConfig, load_config
    from rig.config_checks import check_faults, require_limits
    from rig.host.emulation import EMULATOR_FAULTS
    from rig.host.session import run_config

    if args.duration is not None and args.duration <= 0.0:
        raise UsageError(f"rig run: argument --duration: must be > 0 s, got {args.duration:g}")
    cfg = load_config(args.config)
    if args.fault:
        faults = params_of(args.fault, FaultsConfig, "rig run: --fault")
        bus_faults = sorted(set(faults) & set(EMULATOR_FAULTS))
        if bus_faults and not args.emulate:
            raise UsageError(
                f"rig run: --fault {', '.join(bus_faults)} needs --emulate (the emulator injects it)"
            )
        cfg = dataclasses.replace(cfg, faults=dataclasses.replace(cfg.faults, **faults))
        try:
            check_faults("rig run: --fault", cfg.faults)
        except ConfigError as exc:
            raise UsageError(str(exc)) from None
    if not args.no_limits:
        require_limits(cfg)
    if args.reset_fault:
        axes = tuple(dataclasses.replace(a, reset_fault=True) if a.kind == "cia402" else a for a in cfg.axes)
        cfg = dataclasses.replace(cfg, axes=axes)
    bar = Progress("rig run", 0, "cycles", json=args.json)
    try:
        summary = run_config(cfg, emulate=args.emulate, duration=args.duration, progress=bar.cycles)
    finally:
        bar.close()
    if args.json:
        print_json(summary)
    else:
        print_summary(summary)
    return exit_code(summary)
