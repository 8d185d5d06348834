"""``rig doctor``: what this PC gives a real-time loop, the floor measured at each period with and
without the PM QoS request, a verdict per period and what to change (``rig.doctor``)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rig.cli.common import UsageError, add_json, finite

__all__ = ["add_parser"]

PERIODS = (0.001, 0.0004)  #: [s] the periods judged by default: 1 ms and the paper's 0.4 ms


def add_parser(sub: Any) -> None:
    """``rig doctor``'s parser, added to ``sub``.

    Parameters
    ----------
    sub : Any
        argparse's sub-parsers (``add_subparsers``).
    """
    doctor = sub.add_parser(
        "doctor",
        help="tell whether this PC can run a real-time period, and what to change",
        description="Reads what the kernel gives a real-time loop (preemption model, cpuidle driver, states "
        "and halt polling, SCHED_FIFO, mlockall and PM QoS granted, real-time throttling, frequency "
        "governor, isolated CPUs, a hypervisor's steal, SocketCAN and vcan), measures the floor at each "
        "period as cyclictest does (a loop that only sleeps to its deadlines, with the PM QoS CPU latency "
        "request a real-time run holds and without it), then gives a verdict per period and what to "
        "change, each line naming the setting. See docs/time.md.",
    )
    doctor.add_argument(
        "--period",
        type=finite,
        action="append",
        metavar="S",
        help="a period to judge [s] (repeatable; default 0.001 and 0.0004)",
    )
    doctor.add_argument(
        "--seconds", type=finite, default=3.0, metavar="S", help="each floor measurement's length [s] (3)"
    )
    add_json(doctor, "print one JSON document")
    doctor.set_defaults(handler=run)


def report(periods: list[float], seconds: float) -> dict[str, Any]:
    """The probes, the floors, the verdicts and the advice, as one document."""
    from rig.bench.steadiness import cpu_steadiness
    from rig.doctor.probes import probe_all
    from rig.doctor.verdict import advice, floors, verdicts

    facts = probe_all()
    measured = floors(periods, seconds)
    steady = cpu_steadiness(min(periods), seconds)
    return facts | {
        "floor": measured,
        "cpu_steadiness": steady,
        "verdicts": verdicts(measured),
        "advice": advice(facts, measured, steady),
    }


def _lines(doc: dict[str, Any]) -> list[str]:
    from rig.bench.steadiness import described

    k, idle, g = doc["kernel"], doc["cpuidle"], doc["granted"]
    states = ", ".join(
        f"{s['name']} {s['exit_latency_us']} us{' (disabled)' if s['disabled'] else ''}"
        for s in idle["states"]
    )
    poll = (idle.get("haltpoll") or {}).get("guest_halt_poll_ns")
    t, iso, h, c = doc["throttling"], doc["isolation"], doc["hypervisor"], doc["can"]
    rows = [
        ("kernel", f"{k['release']}, {k['preemption']}" + (f" ({k['mode']})" if k["mode"] else "")),
        (
            "cpuidle",
            f"{idle['driver']} ({idle['governor']}): {states or 'no states'}"
            + (f"; guest_halt_poll_ns {poll}" if poll is not None else ""),
        ),
        ("SCHED_FIFO", "granted" if g["sched_fifo"] else f"refused: {g['sched_fifo_refused']}"),
        ("mlockall", "granted" if g["mlockall"] else f"refused: {g['mlockall_refused']}"),
        ("PM QoS", f"granted ({g['pm_qos_device']})" if g["pm_qos"] else f"refused: {g['pm_qos_refused']}"),
        ("RT throttling", f"{t['runtime_us']} of {t['period_us']} us"),
        ("freq governor", ", ".join(f"{c_} {v}" for c_, v in doc["cpufreq"]["governors"].items()) or "none"),
        ("isolated CPUs", f"{iso['isolated'] or 'none'} (nohz_full {iso['nohz_full'] or 'none'})"),
        (
            "hypervisor",
            ("yes" if h["virtual"] else "no")
            + (f", {h['stolen_since_boot_s']:.1f} s stolen since boot" if h["stolen_since_boot_s"] else ""),
        ),
        (
            "SocketCAN",
            ("yes" if c["socketcan"] else f"no ({c['socketcan_refused']})")
            + f"; CAN interfaces {', '.join(c['interfaces']) or 'none'}",
        ),
    ]
    lines = [f"{key:15s} {text}" for key, text in rows]
    lines.append(f"{'CPU speed':15s} {described(doc['cpu_steadiness'])}")
    for v in doc["verdicts"]:
        lines.append(
            f"{'period ' + format(v['period_s'] * 1e6, 'g') + ' us':15s} {v['verdict'].upper()}: {v['why']}"
        )
    for a in doc["advice"]:
        lines.append(f"{'change':15s} {a['setting']}: {a['now']}: {a['change']}")
    return lines


def run(args: argparse.Namespace) -> int:
    periods = args.period or list(PERIODS)
    for p in periods:
        if not 0.0 < p <= 1.0:
            raise UsageError(f"rig doctor: argument --period: must be in (0, 1] s, got {p:g}")
    if not 0.0 < args.seconds <= 600.0 or any(args.seconds < p for p in periods):
        raise UsageError(
            f"rig doctor: argument --seconds: must be in [the period, 600] s, got {args.seconds:g}"
        )
    doc = report(periods, args.seconds)
    if args.json:
        print(json.dumps(doc))
    else:
        print("\n".join(_lines(doc)))
    return 0
