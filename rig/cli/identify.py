"""``rig identify``: a_m, b_m of (3.5) from a PRBS (or step) experiment on the drive, or from a run log."""

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
from rig.config.params import parse_items

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
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
    ident.add_argument(
        "--clock", type=finite, help="PRBS bit time [s], a few times < 1/a_m (0.02; friction: 0.25)"
    )
    add_json(ident, "print one JSON object")
    add_plot(ident, "the measured and the model's speed (identify.png), or the Bode plot (bode.png)")
    ident.add_argument(
        "--strict", action="store_true", help="exit 5 when a warning says the result is not to be trusted"
    )
    ident.set_defaults(handler=run)


MAX_DURATION = 3600.0  #: [s] the longest experiment


#: periods of 1/f_min in a chirp or multisine experiment by default: the first is dropped (the
#: start's transient), the rest are Welch's averages
PERIODS = 41
#: a chirp's or multisine's dither, a fraction of the amplitude (standard deviation): white
#: noise that keeps the encoder's quantisation error from repeating period after period, where
#: it would bias H1 with a coherence near 1 (a 4096-count encoder at 5 Hz: 16 deg at 170 Hz
#: without, within 4 deg with it)
DITHER = 0.005


def _frequency(args: argparse.Namespace) -> bool:
    """The excitation measures the frequency response (and the defaults that follow)."""
    from rig.identify.frequency import FREQUENCY_EXCITATIONS

    if args.f_min <= 0.0:
        raise UsageError(f"rig identify: argument --f-min: must be > 0 Hz, got {args.f_min:g}")
    if args.f_max is not None and args.f_max <= args.f_min:
        raise UsageError(f"rig identify: need 0 < --f-min ({args.f_min:g}) < --f-max ({args.f_max:g}) [Hz]")
    return args.excitation in FREQUENCY_EXCITATIONS


def _check(args: argparse.Namespace) -> None:
    """The experiment's numbers, before anything is opened."""
    if args.excitation is None:  # a torque's PRBS on u0 > 0 runs away where B is small: both directions
        args.excitation = "friction" if args.input == "torque" else "prbs"
    friction = args.excitation == "friction"
    if args.duration is None:
        args.duration = PERIODS / args.f_min if _frequency(args) else (10.0 if friction else 5.0)
    if args.clock is None:
        args.clock = 0.25 if friction else 0.02
    if not 0.0 < args.duration <= MAX_DURATION:
        raise UsageError(
            f"rig identify: argument --duration: must be in (0, {MAX_DURATION:g}] s, got {args.duration:g}"
        )
    if not 0.0 < args.clock < args.duration:
        raise UsageError(f"rig identify: argument --clock: must be in (0, --duration) s, got {args.clock:g}")
    if args.seed < 0:
        raise UsageError(f"rig identify: argument --seed: must be >= 0, got {args.seed}")


def _experiment(args: argparse.Namespace) -> str | int:
    """Run the experiment; its run directory, or the exit code after a safe stop (3; 4 where the
    stop was not confirmed)."""
    from plant_emulator.presets import PRESETS
    from rig.cli.progress import Progress
    from rig.config import load_config
    from rig.config.emulator import physics
    from rig.identify.experiment import experiment_config, run_experiment
    from rig.papers.demo import demo_config

    _check(args)
    torque = args.input == "torque"
    args.u0 = (0.01 if torque else 3.0) if args.u0 is None else args.u0
    if args.amplitude is None:
        args.amplitude = 0.006 if torque else 2.0
    closed = _frequency(args) and (torque or args.loop_model is not None)
    if args.excitation == "friction" or closed:
        if not 0.0 < args.amplitude:
            raise UsageError(f"rig identify: need --amplitude > 0, got {args.amplitude:g}")
    elif not 0.0 < args.amplitude < args.u0:
        raise UsageError(f"rig identify: need 0 < --amplitude ({args.amplitude:g}) < --u0 ({args.u0:g})")
    if args.emulate and args.emulate not in PRESETS:
        base, params = _twin(args), None
        period = base.period
    elif args.emulate:
        where = "rig identify: --param"
        params, built = physics(
            args.emulate, parse_items(args.param, where), f"rig identify: --emulate {args.emulate}", text=True
        )
        base, period = demo_config(), float(built.period)
    else:
        if args.param:
            raise UsageError("rig identify: --param sets a parameter of the --emulate preset")
        base = load_config(args.config)
        period, params = base.run.period, None
        if period <= 0.0:
            raise UsageError(f"rig identify: {args.config}: [run] period must be set")
    if args.clock < period:
        raise UsageError(
            f"rig identify: argument --clock: {args.clock:g} s is shorter than the period T = {period:g} s"
        )
    loop = _loop_model(args) if closed else None
    u, repeat, dither = _excitation(args, period, closed=closed)
    cfg = experiment_config(
        base,
        u,
        preset=args.emulate,
        params=params,
        input=args.input,
        one_sign=args.excitation != "friction",
        repeat=repeat,
        dither=dither,
        seed=args.seed,
        loop=None if loop is None else _loop(args, loop, u[:repeat], period),
    )
    args.plot_dir = plot_folder(args, "rig identify", old_file=True)  # said before the experiment
    bar = Progress("rig identify: experiment", 0, "cycles", json=args.json)
    try:
        summary = run_experiment(cfg, emulate=bool(args.emulate), progress=bar.cycles)
    finally:
        bar.close()
    if summary["safe_stop_reason"] or summary.get("stop_confirmed") is False:
        why = summary["safe_stop_reason"] or "the drive's stop was not confirmed"
        print(f"rig identify: the experiment stopped: {why}", file=sys.stderr)
        return EXIT_UNCONFIRMED if summary.get("stop_confirmed") is False else EXIT_STOPPED
    return str(summary["run_dir"])


def _twin(args: argparse.Namespace) -> Any:
    """The demo's configuration on the zoo's twin ``--emulate DEVICE`` (its own physics and
    units; ``--param`` over the twin's values), in CST: a commercial drive has no voltage mode."""
    from drivers.errors import ConfigError
    from plant_emulator.device_profile import device_profile
    from rig.config import rig_config
    from rig.config.emulator import preset_params
    from rig.papers.demo import demo_doc

    try:
        profile = device_profile(args.emulate)
    except ConfigError as exc:
        raise UsageError(
            f"rig identify: --emulate {args.emulate}: {exc} (a preset or a zoo twin: rig emulate --list)"
        ) from None
    if args.input != "torque":
        raise UsageError(
            f"rig identify: --emulate {args.emulate}: a commercial drive's twin takes a torque (CST): "
            "give --input torque"
        )
    where = f"rig identify: --emulate {args.emulate}: --param"
    items = parse_items(args.param, where)
    params = preset_params(profile.physics, items, where, text=True, base=profile.params)
    doc = demo_doc()
    doc["emulator"] = {"device": args.emulate, "params": params}
    doc["axis"][0]["mode"] = "cst"
    doc["controller"] = {"kind": "replay", "reads": ["motor"], "commands": ["motor"], "u": [0.0]}
    return rig_config(doc, f"rig identify --emulate {args.emulate}")


def _loop_model(args: argparse.Namespace) -> tuple[float, float]:
    """(a_m, b_m) of ``--loop-model`` for the closed-loop experiment's speed loop."""
    from drivers.errors import ConfigError
    from rig.config.model import read_model

    if args.loop_model is None:
        raise UsageError(
            f"rig identify: --input torque --excitation {args.excitation}: a torque on a plant with little "
            "damping runs away in open loop; the response is measured under a weak speed loop whose gains "
            "need J: give --loop-model RUN_DIR of a rig identify --input torque (the friction experiment)"
        )
    try:
        model = read_model(args.loop_model, where="rig identify: --loop-model")
    except ConfigError as exc:
        raise UsageError(str(exc)) from None
    if model.input != args.input or not model.b_m > 0.0:
        raise UsageError(
            f"rig identify: --loop-model {model.source}: b_m = {model.b_m:g} per unit of {model.input}: "
            f"expected b_m > 0 with --input {args.input} (identify with --input {args.input} first)"
        )
    return model.a_m, model.b_m


def _loop(args: argparse.Namespace, model: tuple[float, float], r: Any, period: float) -> dict[str, float]:
    """The closed-loop experiment's speed loop ({"speed", "kp", "ki"}) on ``model`` = (a_m, b_m)
    for one period ``r`` of the excitation (``rig.identify.closed_loop``)."""
    from rig.identify.closed_loop import LOOP_FRACTION, SPEED_MARGIN, speed_loop, speed_swing
    from rig.identify.experiment import SPEED_LIMIT

    bandwidth = LOOP_FRACTION * args.f_min if args.loop_bandwidth is None else args.loop_bandwidth
    if not 0.0 < bandwidth < args.f_min:
        raise UsageError(
            f"rig identify: argument --loop-bandwidth: {bandwidth:g} Hz: expected 0 < it < --f-min "
            f"({args.f_min:g} Hz), a loop weak over the band measured"
        )
    a, b = model
    kp, ki = speed_loop(b, bandwidth)
    swing = speed_swing(r, period, a=max(a, 0.0), b=b, kp=kp, ki=ki)
    speed = SPEED_MARGIN * swing if args.speed is None else args.speed
    if not abs(speed) > swing or abs(speed) + swing > SPEED_LIMIT:
        raise UsageError(
            f"rig identify: the closed-loop experiment's speed {speed:g} rad/s: the excitation swings the "
            f"speed by {swing:.3g} rad/s (--amplitude {args.amplitude:g} at --f-min {args.f_min:g} Hz), so "
            f"the speed needs {swing:.3g} < |--speed| <= {SPEED_LIMIT - swing:.3g} rad/s; lower --amplitude "
            "or raise --f-min"
        )
    return {"speed": speed, "kp": kp, "ki": ki}


def _excitation(args: argparse.Namespace, period: float, *, closed: bool = False) -> tuple[Any, int, float]:
    """(u, its period in samples or 0, the dither) of the experiment at ``period`` [s]; ``closed``:
    the excitation r about 0 of the closed-loop experiment."""
    from rig.identify.estimate import IdentificationError, excitation
    from rig.identify.frequency import period_samples, periodic_excitation

    if args.excitation == "friction":
        from rig.identify.friction import friction_excitation

        u = friction_excitation(
            amplitude=args.amplitude, clock=args.clock, dt=period, duration=args.duration, seed=args.seed
        )
        return u, 0, 0.0
    if not _frequency(args):
        kw = {"u0": args.u0, "amplitude": args.amplitude, "clock": args.clock, "seed": args.seed}
        return excitation(args.excitation, dt=period, duration=args.duration, **kw), 0, 0.0
    try:
        u = periodic_excitation(
            args.excitation,
            u0=0.0 if closed else args.u0,
            amplitude=args.amplitude,
            dt=period,
            duration=args.duration,
            f_min=args.f_min,
            f_max=args.f_max,
        )
    except IdentificationError as exc:
        raise UsageError(f"rig identify: --f-min/--f-max: {exc}") from exc
    return u, period_samples(args.f_min, period), DITHER * args.amplitude


def _response(args: argparse.Namespace, run_dir: str, result: Any) -> dict[str, Any] | None:
    """The frequency response of a chirp or multisine experiment (or a log, with --excitation)."""
    if args.excitation is None or not _frequency(args):
        return None
    from rig.identify.experiment import frequency_from_log

    return frequency_from_log(run_dir, result, args.excitation, f_min=args.f_min, f_max=args.f_max)


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


def run(args: argparse.Namespace) -> int:
    from drivers.files import read_json
    from rig.cli.identify_report import print_result
    from rig.identify.estimate import IdentificationError
    from rig.identify.experiment import identify_from_log, run_controller
    from rig.identify.model_file import FILE, checks, write_identification

    try:
        if args.from_log:
            args.plot_dir = plot_folder(args, "rig identify", old_file=True)
        run_dir = args.from_log or _experiment(args)  # the experiment makes args.plot_dir first
        folder = args.plot_dir
        if isinstance(run_dir, int):
            return run_dir
        frequency = args.excitation is not None and _frequency(args)
        result = identify_from_log(run_dir, f_min=args.f_min if frequency else None, f_max=args.f_max)
        response = _response(args, run_dir, result)
    except IdentificationError as exc:
        raise UsageError(f"rig identify: {exc}") from exc
    closed_loop, warnings = checks(result, run_controller(run_dir))
    extra: dict[str, Any] = {} if args.excitation is None else {"excitation": args.excitation}
    if response is not None:
        extra["frequency_response"] = response
        extra["bode_plot"] = _bode(
            run_dir, response, args.plot_file or (str(folder / "bode.png") if folder else None)
        )
    try:
        path = write_identification(Path(run_dir), result, closed_loop, warnings, extra)
    except OSError as exc:
        raise UsageError(f"rig identify: {Path(run_dir) / FILE}: cannot be written: {exc}") from exc
    for warning in warnings:
        print(f"rig identify: warning: {warning}", file=sys.stderr)
    if folder is not None and response is None:
        from rig.identify.plots import plot_identify

        plot_identify(run_dir, result, args.plot_file or str(folder / "identify.png"))
    code = EXIT_UNTRUSTED if args.strict and warnings else 0
    if args.json:
        print_json(read_json(path, what="identification"))
        return code
    print_result(result, run_dir, response, extra.get("bode_plot"), path)
    return code
