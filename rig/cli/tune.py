"""``rig tune LAW --from-identify FILE|RUN_DIR``: a law designed from an identification, with its
gain, phase and delay margins on the measured frequency response (``rig.identify.tune``)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from rig.cli.common import EXIT_UNTRUSTED, UsageError, add_json, finite
from rig.cli.language import deprecated

__all__ = ["add_parser"]

LAWS = ("position-servo", "pi-speed", "cascade-position")  #: rig.identify.tune.LAWS


def add_parser(sub: Any) -> None:
    """``rig tune``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    tune = sub.add_parser(
        "tune",
        help="design a law from rig identify's result and check its margins on the measured plant",
        description="Designs position-servo ((7.30) from --lam), pi-speed (from --bandwidth) or "
        "cascade-position (VII.D from --speed-bandwidth and --position-bandwidth) on the identified "
        "(3.5), and computes the loop's gain, phase and delay margins on the measured frequency "
        "response (rig identify --excitation multisine; it holds the drive's, the bus's and the "
        "host's delay and the ZOH) and on the model. --json prints the design, which "
        '[controller] kind = LAW with design = "FILE" runs.',
    )
    tune.add_argument("law", choices=LAWS, help="the [controller] kind to design")
    tune.add_argument(
        "--from-identify", required=True, metavar="FILE|RUN_DIR", help="rig identify's identification.json"
    )
    tune.add_argument("--lam", type=finite, help="position-servo: sliding eigenvalue lambda [1/s], < 0")
    tune.add_argument("--h", type=finite, default=16.0, help="position-servo: (7.30)'s integral gain [1/s]")
    tune.add_argument("--bandwidth", type=finite, help="pi-speed: the speed loop's crossover [Hz]")
    tune.add_argument("--speed-bandwidth", type=finite, help="cascade-position: speed loop [Hz]")
    tune.add_argument("--position-bandwidth", type=finite, help="cascade-position: position loop [Hz]")
    tune.add_argument(
        "--u-max", type=finite, help="the command's limit [V or N m] (cascade-position: needed)"
    )
    tune.add_argument(
        "--speed-max",
        type=finite,
        default=100.0,
        help="cascade-position: the speed reference's limit [rad/s]",
    )
    tune.add_argument(
        "--period", type=finite, metavar="S", help="sample period T [s] (default: the identification's)"
    )
    deprecated(tune, "--dt", "--period", "period", type=finite, metavar="S")
    add_json(tune, "print the design as one JSON object")
    tune.add_argument("--strict", action="store_true", help="exit 5 when there is a warning")
    tune.set_defaults(handler=run)


def _check(args: argparse.Namespace) -> None:
    for name in ("bandwidth", "speed_bandwidth", "position_bandwidth", "u_max", "speed_max", "period"):
        value = getattr(args, name)
        if value is not None and value <= 0.0:
            raise UsageError(f"rig tune: argument --{name.replace('_', '-')}: must be > 0, got {value:g}")


def run(args: argparse.Namespace) -> int:
    from rig.identify.tune import TuneRequest, tune

    _check(args)
    req = TuneRequest(
        law=args.law,
        lam=args.lam,
        h=args.h,
        bandwidth=args.bandwidth,
        speed_bandwidth=args.speed_bandwidth,
        position_bandwidth=args.position_bandwidth,
        u_max=args.u_max,
        speed_max=args.speed_max,
        dt=args.period,
    )
    try:
        doc = tune(args.from_identify, req)
    except ValueError as exc:
        raise UsageError(f"rig tune {args.law}: {exc}") from exc
    for warning in doc["warnings"]:
        print(f"rig tune: warning: {warning}", file=sys.stderr)
    code = EXIT_UNTRUSTED if args.strict and doc["warnings"] else 0
    if args.json:
        print(json.dumps(doc))
        return code
    print(
        f"{doc['law']} designed on a_m = {doc['a_m']:.5g} 1/s, b_m = {doc['b_m']:.5g} at T = {doc['dt']:g} s:"
    )
    for key, value in doc["params"].items():
        print(f"  {key} = {value}")
    band = doc["coherent_band"]
    for name in ("measured", "model"):
        m = doc["margins"][name]
        if m is None:
            continue
        where = f" (coherent band {band[0]:g} .. {band[1]:g} Hz)" if name == "measured" else ""
        print(f"  margins on the {name} plant{where}: {_margins(m)}")
    print(f'  run it with [controller] kind = "{doc["law"]}" and design = "FILE" (the --json output)')
    return code


def _margins(m: dict[str, Any]) -> str:
    def num(key: str, fmt: str) -> str:
        return "none" if m[key] is None else format(m[key], fmt)

    return (
        f"phase {num('phase_margin_deg', '.1f')} deg at {num('crossover_hz', '.3g')} Hz, "
        f"gain {num('gain_margin_db', '.2f')} dB at {num('phase_crossover_hz', '.4g')} Hz, "
        f"delay {'none' if m['delay_margin'] is None else format(1e3 * m['delay_margin'], '.3g')} ms"
        f"{'' if m.get('verdict') is None else ': ' + m['verdict']}"
    )
