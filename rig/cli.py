"""The ``rig`` command line: ``main(argv=None) -> int``.

Conventions: ``--help`` on every level; ``--json`` prints one JSON document on
stdout and nothing else there; bad arguments give one line on stderr and exit
code 2. Only this module configures logging.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Sequence
from typing import NoReturn

import numpy as np

from controllers.design import DTSMDesign, design_dtsm
from drivers.errors import RigError
from rig.bench import BENCHMARKS
from rig.demo import run_demo
from rig.plots import plot_dismc, plot_dq_steps
from rig.reproduce import PARAM_NAMES, DismcExample, apply_params, run_dismc
from rig.reproduce_dq import DQ_PARAM_NAMES, PRINTED_TABLES, DqStudy, apply_dq_params, dq_study

__all__ = ["main"]

EXIT_USAGE = 2


class _UsageError(Exception):
    """A command-line argument is wrong; the message names it."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line, raised instead of exiting."""

    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{self.prog}: {message}")


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def _build_parser() -> _Parser:
    parser = _Parser(prog="rig", description="drive-rig: electrical-drive lab rig toolkit.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages to stderr")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    sub.add_parser("demo", help="design and simulate the DC position servo (section VII.B)")

    design = sub.add_parser("design", help="design a controller")
    dsub = design.add_subparsers(dest="kind", required=True, parser_class=_Parser)
    dtsm = dsub.add_parser(
        "dtsm",
        help="DTSM sliding vector, eqs. (6.9), (6.16)-(6.19)",
        description="Design the delta-domain DTSM for dw/dt = -a_m w + b_m u with position "
        "(3.7), or the error-space model (7.28) with --error-space.",
    )
    dtsm.add_argument("--a-m", type=_finite, help="a_m [1/s] (or --from-identify)")
    dtsm.add_argument("--b-m", type=_finite, help="b_m [rad/(V s^2)] (or --from-identify)")
    dtsm.add_argument("--from-identify", metavar="RESULT.json", help="take a_m, b_m from rig identify --json")
    dtsm.add_argument("--dt", type=_finite, required=True, help="sample period T [s], > 0")
    dtsm.add_argument("--lam", type=_finite, required=True, help="sliding eigenvalue lambda [1/s], < 0")
    dtsm.add_argument(
        "--error-space",
        action="store_true",
        help="use (7.28): e = [theta_r - theta, de/dt], b = [0, -b_m]",
    )
    dtsm.add_argument("--json", action="store_true", help="print one JSON object")

    reproduce = sub.add_parser("reproduce", help="reproduce a paper's numerical study")
    rsub = reproduce.add_subparsers(dest="study", required=True, parser_class=_Parser)
    dismc = rsub.add_parser(
        "dismc",
        help="section 4 of the DISMC paper: Table 1 for DSMC, DISMC-LMI, DISMC-LQR, DISMC-AW-LQR",
        description="Runs (47)-(53) with K of (55) and (57). Uses the printed H of (50) unless "
        "--param H=solved. Parameters: " + ", ".join(PARAM_NAMES) + ".",
    )
    dismc.add_argument("--json", action="store_true", help="print a list of JSON objects")
    dismc.add_argument("--plot", metavar="FILE", help="write Fig. 3-like plots to FILE")
    dismc.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override an example parameter by the paper's symbol (repeatable)",
    )

    dq = rsub.add_parser(
        "dq-current",
        help="dq-current paper: Tables II-III and the cross-coupling of a q step (proposed vs PI)",
        description="Runs the controller (32)-(34)/(37) on the plant (29) (or the fine stationary-frame "
        "model) with the Table IV parameters. Parameters: " + ", ".join(DQ_PARAM_NAMES) + ".",
    )
    dq.add_argument(
        "--json", action="store_true", help='print one object {"tables": [...], "cross_coupling": [...]}'
    )
    dq.add_argument("--plot", metavar="FILE", help="write q-step responses in dq (Fig. 9(b)-like) to FILE")
    dq.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override: ratio (e.g. 1/27), L1 [H], R1 [Ohm], gamma, strategy, plant (exact|fine)",
    )

    run = sub.add_parser("run", help="run a configured control law over the wire (see examples/)")
    run.add_argument("--config", required=True, metavar="FILE", help="the rig configuration (TOML)")
    run.add_argument("--emulate", action="store_true", help="run the configured emulator preset in-process")
    run.add_argument("--duration", type=_finite, help="override [run] duration [s]")
    run.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    run.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="inject a fault with --emulate (overrides [faults]); names as in [faults] (rig/config.py)",
    )

    scan = sub.add_parser("scan", help="list the CANopen nodes on a bus")
    scan.add_argument("--interface", help="python-can interface (e.g. socketcan, socketcand)")
    scan.add_argument("--channel", help="python-can channel (e.g. vcan0)")
    scan.add_argument("--host", default="127.0.0.1", help="socketcand host")
    scan.add_argument("--port", type=int, default=29536, help="socketcand port")
    scan.add_argument("--emulate", metavar="PRESET", help="scan an in-process emulator preset instead")
    scan.add_argument("--listen", type=_finite, default=1.1, help="seconds to listen for heartbeats")
    scan.add_argument("--json", action="store_true", help="print a list of JSON objects")

    faults = sub.add_parser(
        "faults", help="run every fault scenario over the whole chain and print the table"
    )
    faults.add_argument("--json", action="store_true", help="print a list of JSON objects")
    faults.add_argument("--scenario", action="append", default=[], metavar="NAME", help="run only these")

    ident = sub.add_parser(
        "identify", help="identify a_m, b_m of (3.5) from a PRBS experiment on the drive, or from a run log"
    )
    source = ident.add_mutually_exclusive_group(required=True)
    source.add_argument("--config", metavar="FILE", help="the rig configuration (bus, drive, limits)")
    source.add_argument("--emulate", metavar="PRESET", help="run the experiment on an in-process preset")
    source.add_argument("--from-log", metavar="RUN_DIR", help="estimate from a recorded run directory")
    ident.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="preset parameter")
    ident.add_argument("--excitation", choices=("prbs", "steps"), default="prbs")
    ident.add_argument("--duration", type=_finite, default=5.0, help="experiment length [s]")
    ident.add_argument("--seed", type=int, default=0, help="PRBS seed")
    ident.add_argument("--u0", type=_finite, default=3.0, help="operating point [V] (speed of one sign)")
    ident.add_argument("--amplitude", type=_finite, default=2.0, help="excitation amplitude [V], < u0")
    ident.add_argument("--clock", type=_finite, default=0.02, help="PRBS bit time [s], a few times < 1/a_m")
    ident.add_argument("--json", action="store_true", help="print one JSON object")
    ident.add_argument("--plot", metavar="FILE", help="write measured and model speed to FILE")

    emulate = sub.add_parser(
        "emulate",
        help="run the plant emulator as its own process (a python-can bus, or socketcand on 127.0.0.1)",
    )
    emulate.add_argument("--preset", help="dc-servo, im-drive or grid-converter (CANopen)")
    emulate.add_argument(
        "--modbus-map",
        metavar="NAME",
        help="serve an emulated Modbus inverter of this map instead (abb-drives-profile, delta-vfd-b)",
    )
    emulate.add_argument("--modbus-port", type=int, default=5020, help="Modbus TCP port (default 5020)")
    emulate.add_argument(
        "--modbus-serial", metavar="DEVICE", help="serve Modbus RTU on this serial device instead"
    )
    emulate.add_argument(
        "--listen",
        default="127.0.0.1",
        metavar="ADDRESS",
        help="address the TCP servers (socketcand, Modbus TCP) bind: 127.0.0.1 unless you name another",
    )
    emulate.add_argument("--node-id", type=int, help="node id of the drive (the encoder takes the next one)")
    emulate.add_argument(
        "--interface", help="python-can interface, e.g. socketcan (default: serve socketcand)"
    )
    emulate.add_argument("--channel", help="python-can channel, e.g. vcan0")
    emulate.add_argument(
        "--socketcand-port",
        type=int,
        default=29536,
        help="socketcand TCP port on --listen (0: any free port)",
    )
    emulate.add_argument(
        "--time",
        choices=("realtime", "lockstep"),
        default="realtime",
        help="lockstep: an event RPDO counts as received at its SYNC (for hosts that wait for each answer)",
    )
    emulate.add_argument(
        "--param", action="append", default=[], metavar="NAME=VALUE", help="override a preset parameter"
    )

    bench = sub.add_parser("bench", help="measure and print figures")
    bench.add_argument("name", choices=sorted(BENCHMARKS), help="what to measure")
    bench.add_argument("--json", action="store_true", help='print a list of {"name", "value", "unit"}')
    return parser


def _design_dtsm(args: argparse.Namespace) -> DTSMDesign:
    if args.from_identify:
        try:
            with open(args.from_identify) as f:
                doc = json.load(f)
            args.a_m, args.b_m = float(doc["a_m"]), float(doc["b_m"])
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise _UsageError(f"rig design dtsm: --from-identify {args.from_identify}: {exc}") from exc
    if args.a_m is None or args.b_m is None:
        raise _UsageError("rig design dtsm: give --a-m and --b-m, or --from-identify RESULT.json")
    if args.dt <= 0.0:
        raise _UsageError(f"rig design dtsm: argument --dt: must be > 0 s, got {args.dt:g}")
    if args.lam >= 0.0:
        raise _UsageError(f"rig design dtsm: argument --lam: must be < 0 1/s, got {args.lam:g}")
    b = -args.b_m if args.error_space else args.b_m
    try:
        return design_dtsm(A=[[0.0, 1.0], [0.0, -args.a_m]], b=[0.0, b], dt=args.dt, lam=args.lam)
    except ValueError as exc:
        raise _UsageError(
            f"rig design dtsm: --a-m {args.a_m:g} --b-m {args.b_m:g} --dt {args.dt:g}: {exc}"
        ) from exc


def _print_design(d: DTSMDesign, out: object) -> None:
    lines = [
        f"DTSM design, T = {d.dt:g} s (eqs. 6.9, 6.16-6.19)",
        f"  A_delta         = {[list(r) for r in d.A_delta]}",
        f"  b_delta         = {list(d.b_delta)}",
        f"  lambda_delta    = {d.lambda_delta:.10g} 1/s",
        f"  k_delta         = {list(d.k_delta)}",
        f"  c_delta         = {list(d.c_delta)}",
        f"  c_delta A_delta = {list(d.c_delta_A_delta)}",
    ]
    print("\n".join(lines), file=out)  # type: ignore[call-overload]


def _json_number(v: float) -> float | None:
    return v if math.isfinite(v) else None


def _reproduce_dismc(args: argparse.Namespace) -> int:
    try:
        example = apply_params(DismcExample(), args.param)
        runs = run_dismc(example)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise _UsageError(f"rig reproduce dismc: {exc}") from exc
    if args.plot:
        plot_dismc(runs, args.plot, dt=example.Ts)
    rows = [{"controller": r.controller, **{k: _json_number(v) for k, v in r.metrics.items()}} for r in runs]
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"DISMC paper, section 4 (H {example.H}; Ts = {example.Ts} s); Table 1 metrics:")
    print(f"  {'controller':14s} {'rise s':>8s} {'settling s':>11s} {'u_min':>9s} {'u_max':>9s}")
    for r in rows:
        cells = [f"{v:.2f}" if isinstance(v, float) else "-" for v in list(r.values())[1:]]
        print(f"  {r['controller']:14s} {cells[0]:>8s} {cells[1]:>11s} {cells[2]:>9s} {cells[3]:>9s}")
    print(
        "  paper: DISMC-LMI 1.82 2.88 -60.6 135.8; DISMC-LQR 0.44 0.72 -32.7 175.1;"
        " DISMC-AW-LQR 0.32 0.38 -11.1 104.5"
    )
    return 0


def _reproduce_dq(args: argparse.Namespace) -> int:
    try:
        study = apply_dq_params(DqStudy(), args.param)
        rows, runs = dq_study(study)
    except ValueError as exc:
        raise _UsageError(f"rig reproduce dq-current: {exc}") from exc
    if args.plot:
        plot_dq_steps(runs, args.plot)
    cross = [
        {
            "strategy": r.strategy,
            "ratio": r.ratio,
            "controller": r.controller,
            "gamma": r.gamma,
            "peak_id": r.peak_id,
        }
        for r in runs
    ]
    if args.json:
        tables = [{k: _json_number(v) if isinstance(v, float) else v for k, v in row.items()} for row in rows]
        print(json.dumps({"tables": tables, "cross_coupling": cross}))
        return 0
    print(
        f"dq-current paper, Tables II-III (plant {study.plant}, L1 = {study.L1:g} H, R1 = {study.R1:g} Ohm)"
    )
    print(
        f"  {'strategy':13s} {'variant':8s} {'gamma':>5s} {'bw/fs':>6s} {'GM dB':>6s} {'PM deg':>6s} "
        f"{'OS %':>5s} {'rise':>4s} {'settle':>6s}   printed: bw GM PM OS rise settle"
    )
    for row in rows:
        printed = PRINTED_TABLES[row["strategy"]].get(row["gamma"])
        cells = [
            row[k] for k in ("bandwidth_ratio", "gain_margin_db", "phase_margin_deg", "overshoot_percent")
        ]
        head = f"  {row['strategy']:13s} {row['variant']:8s} {row['gamma']:5.2f} "
        print(
            f"{head}{cells[0]:6.3f} {cells[1]:6.2f} {cells[2]:6.1f} {cells[3]:5.1f} "
            f"{row['rise_samples']:4.0f} {row['settling_samples']:6.0f}   "
            + (" ".join(f"{v:g}" for v in printed) if printed else "-")
        )
    print("Cross-coupling: peak |i_d| per unit q-reference step")
    for c in cross:
        ratio = float(c["ratio"])  # type: ignore[arg-type]
        print(
            f"  {c['strategy']:13s} w_k/w_s = 1/{1 / ratio:<5.4g} gamma {c['gamma']:.2f} "
            f"{c['controller']:13s} {c['peak_id']:.4f}"
        )
    return 0


def _emulate(args: argparse.Namespace) -> int:
    from rig.emulate import run_emulator

    overrides = {}
    for item in args.param:
        name, sep, value = item.partition("=")
        if not sep:
            raise _UsageError(f"rig emulate: --param {item!r}: expected NAME=VALUE")
        overrides[name.strip()] = value.strip()
    if args.node_id is not None:
        if not 1 <= args.node_id <= 126:
            raise _UsageError(f"rig emulate: --node-id {args.node_id}: must be 1..126")
        overrides["drive_node"] = str(args.node_id)
        if args.preset in ("dc-servo", "im-drive"):
            overrides["encoder_node"] = str(args.node_id + 1)
    if args.interface and not args.channel:
        raise _UsageError("rig emulate: --interface needs --channel")
    try:
        if args.modbus_map:
            from rig.emulate import run_modbus_emulator

            return run_modbus_emulator(
                args.modbus_map, overrides, host=args.listen, port=args.modbus_port, serial=args.modbus_serial
            )
        if not args.preset:
            raise _UsageError("rig emulate: give --preset (CANopen) or --modbus-map (Modbus)")
        return run_emulator(
            args.preset,
            overrides,
            interface=args.interface,
            channel=args.channel,
            host=args.listen,
            port=args.socketcand_port,
            lockstep=args.time == "lockstep",
        )
    except ValueError as exc:
        raise _UsageError(f"rig emulate: {exc}") from exc


def _rig_run(args: argparse.Namespace) -> int:
    from rig.config import load_config
    from rig.run import run_config

    if args.duration is not None and args.duration <= 0.0:
        raise _UsageError(f"rig run: argument --duration: must be > 0 s, got {args.duration:g}")
    cfg = load_config(args.config)
    if args.fault:
        import dataclasses

        from plant_emulator.faults import parse_faults

        if not args.emulate:
            raise _UsageError("rig run: --fault needs --emulate (faults are injected by the emulator)")
        try:
            plan = parse_faults(args.fault)
        except ValueError as exc:
            raise _UsageError(f"rig run: {exc}") from exc
        changed = {k: v for k, v in dataclasses.asdict(plan).items() if v != getattr(type(plan)(), k)}
        cfg = dataclasses.replace(cfg, faults=dataclasses.replace(cfg.faults, **changed))
    summary = run_config(cfg, emulate=args.emulate, duration=args.duration)
    if args.json:
        print(json.dumps({k: _json_number(v) if isinstance(v, float) else v for k, v in summary.items()}))
    else:
        for key in (
            "cycles",
            "rms_error",
            "max_error",
            "chattering_count",
            "overruns",
            "safe_stop_reason",
            "run_dir",
        ):
            print(f"{key:18s} {summary[key]}")
    return 0 if summary["safe_stop_reason"] is None else 3


def _scan(args: argparse.Namespace) -> int:
    import canopen

    from drivers.bus import open_bus
    from plant_emulator.lockstep import SyncHub, attach_network
    from plant_emulator.presets import build_preset
    from rig.scan import scan, wall_listen

    network = canopen.Network()
    if args.emulate:
        hub = SyncHub()
        devices_net = canopen.Network()
        attach_network(devices_net, hub.bus(queue=False))
        attach_network(network, hub.bus(queue=False))
        try:
            devices, period = build_preset(args.emulate, devices_net)
        except ValueError as exc:
            raise _UsageError(f"rig scan: --emulate {args.emulate}: {exc}") from exc
        for d in devices:
            d.boot()

        def listen() -> None:  # advance emulated time by --listen seconds
            for k in range(1, round(args.listen / period) + 1):
                for d in devices:
                    d.tick(k * period)

        rows = scan(network, listen=listen)
        for bus in list(hub.buses):
            bus.shutdown()
    else:
        if not (args.interface and (args.channel or args.interface == "socketcand")):
            raise _UsageError("rig scan: give --interface and --channel, or --emulate PRESET")
        extra = {"host": args.host, "port": args.port} if args.interface == "socketcand" else {}
        network.bus = open_bus(args.interface, args.channel or "can0", **extra)
        network.connect()
        try:
            rows = scan(network, listen=wall_listen(args.listen))
        finally:
            network.disconnect()
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{'node':>4s}  {'NMT state':16s} {'device type':12s} {'profile':18s} {'vendor':11s} product")
    for r in rows:
        product = r.get("product_name", r.get("error", ""))
        print(
            f"{r['node_id']:>4d}  {r['nmt_state']:16s} {r.get('device_type', '-'):12s} "
            f"{r.get('profile', '-'):18s} {r.get('vendor_id', '-'):11s} {product}"
        )
    return 0


def _identify(args: argparse.Namespace) -> int:
    from plant_emulator.presets import preset_period
    from rig.config import load_config
    from rig.demo import demo_config
    from rig.emulate import preset_values
    from rig.experiment import experiment_config, identify_from_log, run_experiment, terminal_progress
    from rig.identify import IdentificationError, excitation

    run_dir = args.from_log
    try:
        if not run_dir:
            if not 0.0 < args.amplitude < args.u0:
                raise _UsageError(
                    f"rig identify: need 0 < --amplitude ({args.amplitude:g}) < --u0 ({args.u0:g})"
                )
            overrides = dict(item.split("=", 1) for item in args.param if "=" in item)
            if len(overrides) != len(args.param):
                raise _UsageError(f"rig identify: --param needs NAME=VALUE, got {args.param}")
            if args.emulate:
                cfg = experiment_config(demo_config(), preset=args.emulate, params=overrides)
                period = preset_period(args.emulate, preset_values(args.emulate, overrides))
            else:
                cfg = load_config(args.config)
                period = cfg.run.period
                if period <= 0.0:
                    raise _UsageError(f"rig identify: {args.config}: [run] period must be set")
            u = excitation(
                args.excitation,
                u0=args.u0,
                amplitude=args.amplitude,
                clock=args.clock,
                dt=period,
                duration=args.duration,
                seed=args.seed,
            )
            summary = run_experiment(cfg, u, emulate=bool(args.emulate), progress=terminal_progress)
            if sys.stderr.isatty():
                sys.stderr.write("\n")
            if summary["safe_stop_reason"]:
                print(f"rig identify: the experiment stopped: {summary['safe_stop_reason']}", file=sys.stderr)
                return 3
            run_dir = summary["run_dir"]
        result = identify_from_log(run_dir)
    except (IdentificationError, ValueError) as exc:
        raise _UsageError(f"rig identify: {exc}") from exc
    if args.plot:
        from rig.plots import plot_identify

        plot_identify(run_dir, result, args.plot)
    doc = {**result.as_dict(), "run_dir": str(run_dir)}
    if args.json:
        print(json.dumps(doc))
        return 0
    r = result
    print(f"identified (3.5) from {r.samples} samples at T = {r.dt:g} s ({run_dir}):")
    for name, unit in (("a_m", "1/s"), ("b_m", "rad/(V s^2)")):
        value, err, (low, high) = getattr(r, name), getattr(r, f"{name}_stderr"), getattr(r, f"{name}_ci95")
        print(f"  {name} = {value:.5g} {unit}, stderr {err:.2g}, 95 %: {low:.5g} .. {high:.5g}")
    print(f"  delay {r.delay_samples} samples, offset {r.offset:.4g} rad/s^2")
    print(f"  fit on held-out data {r.fit_percent:.1f} %")
    return 0


def _faults(args: argparse.Namespace) -> int:
    from rig.fault_suite import SCENARIOS, run_faults

    unknown = [n for n in args.scenario if n not in SCENARIOS]
    if unknown:
        raise _UsageError(f"rig faults: unknown scenario(s) {unknown}; known: {', '.join(SCENARIOS)}")
    rows = run_faults(args.scenario or None)
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{'scenario':18s} {'detected':>9s} {'disabled':>9s} {'lost':>5s}  message")
    for r in rows:
        detected = "-" if r["detected_after_cycles"] is None else str(r["detected_after_cycles"])
        lost = "-" if r["samples_lost"] is None else str(r["samples_lost"])
        print(f"{r['scenario']:18s} {detected:>9s} {r['drive_disabled']!s:>9s} {lost:>5s}  {r['message']}")
    return 0


def _run(args: argparse.Namespace) -> int:
    if args.command == "demo":
        return run_demo(sys.stdout)
    if args.command == "design":
        d = _design_dtsm(args)
        if args.json:
            print(json.dumps(d.as_dict()))
        else:
            _print_design(d, sys.stdout)
        return 0
    if args.command == "reproduce":
        return _reproduce_dismc(args) if args.study == "dismc" else _reproduce_dq(args)
    if args.command == "faults":
        return _faults(args)
    if args.command == "identify":
        return _identify(args)
    if args.command == "scan":
        return _scan(args)
    if args.command == "run":
        return _rig_run(args)
    if args.command == "emulate":
        return _emulate(args)
    if args.command == "bench":
        figures = BENCHMARKS[args.name]()
        if args.json:
            print(json.dumps(figures))
        else:
            for f in figures:
                print(f"{f['name']:28s} {f['value']:>10} {f['unit']}")
        return 0
    raise _UsageError(f"rig: unknown command {args.command!r}")  # pragma: no cover


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``rig`` command line; returns the process exit code."""
    parser = _build_parser()
    try:
        args = parser.parse_args(argv)
        logging.basicConfig(
            level=logging.DEBUG if args.verbose else logging.WARNING,
            stream=sys.stderr,
            format="%(levelname)s %(name)s: %(message)s",
        )
        return _run(args)
    except _UsageError as exc:
        print(str(exc), file=sys.stderr)
        return EXIT_USAGE
    except RigError as exc:
        print(f"rig: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("rig: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
