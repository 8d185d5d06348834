"""``rig identify``: a_m, b_m of (3.5) from a PRBS (or step) experiment on the drive, or from a run log.

The command parses and prints; the experiment is planned by ``rig.identify.plan`` and run by
``rig.identify.experiment``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rig.cli.common import (
    EXIT_STOPPED,
    EXIT_UNCONFIRMED,
    EXIT_UNTRUSTED,
    UsageError,
    add_json,
    add_params,
    add_plot,
    finite,
    plot_folder,
    print_json,
)

__all__ = ["add_parser", "run"]

WHO = "rig identify"


def add_parser(sub: Any) -> None:
    """``rig identify``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    ident = sub.add_parser(
        "identify",
        help="identify a_m, b_m of (3.5) from a PRBS experiment on the drive, or from a run log",
        description="Replays u = u0 + amplitude prbs(t) (or steps) in voltage mode on the axis the "
        "configuration's law commands, through the session like any rig run, and estimates (3.5) with "
        "a delay and an offset (docs/identification.md). The result is written to identification.json "
        "in the run directory (rig design dtsm --from-identify and [controller] design take it). It "
        "warns when the data were taken in closed loop or the held-out fit is below 70 %; with --strict "
        "that exits 5. Example: rig identify --emulate dc-servo --param plant.a_m=23.5",
    )
    source = ident.add_mutually_exclusive_group(required=True)
    source.add_argument("--config", metavar="FILE", help="the rig configuration (bus, axis, limits)")
    source.add_argument(
        "--emulate",
        metavar="NAME",
        help="a preset or a zoo twin (in CST; rig emulate --list) in this process",
    )
    source.add_argument("--from-log", metavar="RUN_DIR", help="estimate from a recorded run directory")
    add_params(ident, "a parameter of the --emulate preset (e.g. plant.a_m=23.5)")
    _add_excitation(ident)
    _add_closed_loop(ident)
    add_json(ident, "print one JSON object")
    add_plot(ident, "the measured and the model's speed (identify.png), or the Bode plot (bode.png)")
    ident.add_argument(
        "--strict", action="store_true", help="exit 5 when a warning says the result is not to be trusted"
    )
    ident.set_defaults(handler=run)


def _add_excitation(ident: Any) -> None:
    """The excitation's options: what it is, how long, its band, its input and amplitude."""
    ident.add_argument(
        "--excitation",
        choices=("prbs", "steps", "chirp", "multisine", "friction"),
        help="prbs (default; with --input torque: friction) or steps for (3.5); chirp or multisine "
        "(periodic, 1/--f-min) also measure the frequency response (with --from-log: compute it from the "
        "log); friction: steps and a slow "
        "ramp of +-amplitude in both directions, for Coulomb and viscous friction and the inertia",
    )
    ident.add_argument(
        "--duration",
        type=finite,
        help="experiment length [s] (5; chirp and multisine: 41 periods of 1/--f-min, 40 averages; "
        "friction: 10)",
    )
    ident.add_argument(
        "--f-min", type=finite, default=1.0, help="lowest frequency [Hz], the excitation's period (1)"
    )
    ident.add_argument("--f-max", type=finite, help="highest frequency [Hz] (a fifth of the sample rate)")
    ident.add_argument("--seed", type=int, default=0, help="PRBS seed")
    ident.add_argument(
        "--input",
        choices=("voltage", "torque"),
        default="voltage",
        help="what u is: the armature voltage (mode -1) or, on a commercial drive, the torque (CST)",
    )
    ident.add_argument(
        "--u0", type=finite, help="operating point [V or N m] (one sign of speed; 3 V, 0.01 N m)"
    )
    ident.add_argument("--amplitude", type=finite, help="excitation amplitude, < u0 (2 V, 0.006 N m)")
    ident.add_argument(
        "--clock", type=finite, help="PRBS bit time [s], a few times < 1/a_m (0.02; friction: 0.25)"
    )


def _add_closed_loop(ident: Any) -> None:
    """The options of a frequency response measured in closed loop."""
    ident.add_argument(
        "--loop-model",
        metavar="FILE|RUN_DIR",
        help="chirp or multisine in closed loop (needed with --input torque): a weak PI speed loop holds "
        "--speed and the excitation is added to its command; its gains from this identification's b_m "
        "(identification.json, e.g. of rig identify --input torque); the response is G_ry/G_ru",
    )
    ident.add_argument(
        "--loop-bandwidth",
        type=finite,
        help="the closed-loop experiment's speed loop crossover [Hz] (f_min/2)",
    )
    ident.add_argument(
        "--speed",
        type=finite,
        help="the closed-loop experiment's speed [rad/s] (twice the excitation's swing)",
    )


def _request(args: argparse.Namespace) -> Any:
    """The options as ``rig.identify.request.Request``."""
    import dataclasses

    from rig.identify.request import Request

    return Request(**{f.name: getattr(args, f.name) for f in dataclasses.fields(Request)})


def _plan(args: argparse.Namespace) -> Any:
    """The experiment's plan (``rig.identify.plan``), on the rig ``--config`` or ``--emulate`` names."""
    from plant_emulator.presets import PRESETS
    from rig.identify.plan import on_file, on_preset, on_twin, plan_experiment
    from rig.identify.request import PlanError
    from rig.papers.demo import demo_config, demo_doc

    try:
        if not args.emulate:
            base = on_file(args.config, args.param)
        elif args.emulate in PRESETS:
            base = on_preset(args.emulate, args.param, demo_config())
        else:
            base = on_twin(args.emulate, args.param, args.input, demo_doc())
        return plan_experiment(_request(args), base)
    except PlanError as exc:
        raise UsageError(f"{WHO}: {exc}") from None


def _experiment(plan: Any, json: bool) -> str | int:
    """Run the planned experiment: its run directory, or the exit code after a safe stop (3; 4
    where the stop was not confirmed)."""
    from rig.cli.progress import Progress
    from rig.identify.experiment import run_experiment

    bar = Progress(f"{WHO}: experiment", 0, "cycles", json=json)
    try:
        summary = run_experiment(plan.config, emulate=plan.emulate, progress=bar.cycles)
    finally:
        bar.close()
    if summary["safe_stop_reason"] or summary.get("stop_confirmed") is False:
        why = summary["safe_stop_reason"] or "the drive's stop was not confirmed"
        print(f"{WHO}: the experiment stopped: {why}", file=sys.stderr)
        return EXIT_UNCONFIRMED if summary.get("stop_confirmed") is False else EXIT_STOPPED
    return str(summary["run_dir"])


def _measured(args: argparse.Namespace) -> tuple[str | int, str | None, Any]:
    """(the run directory or an exit code, the excitation, the --plot folder): the experiment
    planned, the folder made and matplotlib checked before it runs, then run; or the log."""
    if args.from_log:
        from rig.identify.request import PlanError, measures_response

        folder = plot_folder(args, WHO, old_file=True)
        try:
            if args.excitation is not None:
                measures_response(_request(args))  # the band checked before the estimate
        except PlanError as exc:
            raise UsageError(f"{WHO}: {exc}") from None
        return args.from_log, args.excitation, folder
    plan = _plan(args)
    folder = plot_folder(args, WHO, old_file=True)  # said before the experiment
    return _experiment(plan, args.json), plan.request.excitation, folder


def _bode(run_dir: str, response: dict[str, Any], path: str | None) -> str | None:
    """The Bode plot to ``path`` (``--plot``'s), else bode.png in the run directory; None there
    without matplotlib (``--plot`` checked it before the experiment)."""
    from drivers.errors import ConfigError
    from rig.identify.bode import plot_bode

    target = path or str(Path(run_dir) / "bode.png")
    try:
        plot_bode(response, target)
    except ConfigError:
        if path:
            raise
        return None
    return target


def _figure(args: argparse.Namespace, folder: Path | None, name: str) -> str | None:
    """The file of ``--plot``'s figure ``name`` (its old form: the file given), None without it."""
    return args.plot_file or (str(folder / name) if folder else None)


def _estimate(run_dir: str, excitation: str | None, args: argparse.Namespace) -> tuple[Any, Any]:
    """(the identification of ``run_dir``, its frequency response or None)."""
    from rig.identify.estimate import IdentificationError
    from rig.identify.experiment import frequency_from_log, identify_from_log
    from rig.identify.frequency import FREQUENCY_EXCITATIONS

    frequency = excitation in FREQUENCY_EXCITATIONS
    try:
        result = identify_from_log(run_dir, f_min=args.f_min if frequency else None, f_max=args.f_max)
        if not frequency:
            return result, None
        response = frequency_from_log(run_dir, result, str(excitation), f_min=args.f_min, f_max=args.f_max)
    except IdentificationError as exc:
        raise UsageError(f"{WHO}: {exc}") from exc
    return result, response


def run(args: argparse.Namespace) -> int:
    """Run ``rig identify``: the experiment (or the log), the estimate, its report.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.

    Returns
    -------
    int
        The exit code: 0; 5 with ``--strict`` and a warning; 3 or 4 after a safe stop.

    Raises
    ------
    UsageError
        If an option is out of range, the estimate fails, or the result cannot be written.
    """
    from drivers.files import read_json
    from rig.cli.identify_report import print_result
    from rig.identify.experiment import run_controller
    from rig.identify.model_file import FILE, checks, write_identification

    run_dir, excitation, folder = _measured(args)
    if isinstance(run_dir, int):
        return run_dir
    result, response = _estimate(run_dir, excitation, args)
    closed_loop, warnings = checks(result, run_controller(run_dir))
    extra: dict[str, Any] = {} if excitation is None else {"excitation": excitation}
    if response is not None:
        extra["frequency_response"] = response
        extra["bode_plot"] = _bode(run_dir, response, _figure(args, folder, "bode.png"))
    try:
        path = write_identification(Path(run_dir), result, closed_loop, warnings, extra)
    except OSError as exc:
        raise UsageError(f"{WHO}: {Path(run_dir) / FILE}: cannot be written: {exc}") from exc
    for warning in warnings:
        print(f"{WHO}: warning: {warning}", file=sys.stderr)
    if folder is not None and response is None:
        from rig.identify.plots import plot_identify

        plot_identify(run_dir, result, str(_figure(args, folder, "identify.png")))
    code = EXIT_UNTRUSTED if args.strict and warnings else 0
    if args.json:
        print_json(read_json(path, what="identification"))
    else:
        print_result(result, run_dir, response, extra.get("bode_plot"), path)
    return code
