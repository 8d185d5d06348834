"""Whether this PC can run a period (``rig doctor``): the measured floor at each period, with the PM
QoS CPU latency request a real-time run holds and without it, a verdict per period, and what to
change, each line naming the setting.

The floor is cyclictest's measure (``rig.bench.floor.sleep_floor``: a loop that only sleeps to
deadlines ``period`` apart under the host loop's real-time request). A period is kept where that
loop, with the request, missed at most 0.1 % of its periods and woke at most a quarter of a
period late at its 99th percentile; marginal up to 1 % and half a period; else not kept. The host
loop adds its own work to the floor (the response's host time, docs/benchmarks.md), so a period
the floor does not keep, no run keeps.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

from rig.bench.floor import sleep_floor
from rig.bench.steadiness import described
from rig.host.realtime import RealtimeRequest

__all__ = ["KEPT", "MARGINAL", "UNSTEADY", "advice", "floors", "verdicts"]

KEPT = (0.001, 0.25)  #: (share of periods missed, lateness p99 in periods) the floor may have: kept
MARGINAL = (0.01, 0.5)  #: ... marginal
#: share of periods whose fixed work took 1.5 times its median or more beyond which the CPU's speed is
#: unsteady (``rig.bench.steadiness``; a PC of its own: well under 1 %)
UNSTEADY = 0.01


def floors(periods: Sequence[float], seconds: float) -> list[dict[str, Any]]:
    """The floor at each period for ``seconds`` [s]: with the PM QoS request and without it.

    Parameters
    ----------
    periods : Sequence[float]
        [s] the periods.
    seconds : float
        [s] at each.

    Returns
    -------
    list[dict[str, Any]]
        Each period's floor, with and without the request.
    """
    out = []
    for period in periods:
        awake = sleep_floor(period, seconds)
        asleep = sleep_floor(period, seconds, RealtimeRequest(cpu_latency=-1))
        out.append({"period_s": period, "with_pm_qos": _shares(awake), "without_pm_qos": _shares(asleep)})
    return out


def _shares(floor: dict[str, Any]) -> dict[str, Any]:
    return floor | {"missed_share": floor["missed"] / max(1, floor["periods"])}


def _grade(floor: dict[str, Any], period: float) -> str:
    missed, late = floor["missed_share"], floor["lateness_us"]["p99"] * 1e-6 / period
    if missed <= KEPT[0] and late <= KEPT[1]:
        return "kept"
    if missed <= MARGINAL[0] and late <= MARGINAL[1]:
        return "marginal"
    return "not kept"


def _why(awake: dict[str, Any], asleep: dict[str, Any]) -> str:
    late, lost = awake["lateness_us"], 100 * awake["missed_share"]
    return (
        f"a loop that only sleeps missed {lost:.3g} % of its periods and woke {late['p99']:.0f} us late at "
        f"p99 (max {late['max']:.0f} us) with the CPU kept awake; {100 * asleep['missed_share']:.3g} % "
        f"and {asleep['lateness_us']['p99']:.0f} us without"
    )


def verdicts(measured: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """A verdict per period, from its floor with the request (what a run gets) and without.

    Parameters
    ----------
    measured : Sequence[dict[str, Any]]
        ``floors``'s result.

    Returns
    -------
    list[dict[str, Any]]
        A verdict per period.
    """
    out = []
    for m in measured:
        period = m["period_s"]
        awake, asleep = m["with_pm_qos"], m["without_pm_qos"]
        out.append(
            {
                "period_s": period,
                "verdict": _grade(awake, period),
                "without_pm_qos": _grade(asleep, period),
                "why": _why(awake, asleep),
            }
        )
    return out


#: one piece of advice: (the setting, what it is now, what to change)
Advice = tuple[str, str, str]


def advice(
    facts: dict[str, Any], measured: Sequence[dict[str, Any]], steady: dict[str, Any] | None = None
) -> list[dict[str, str]]:
    """What to change, each naming the setting, from the probes, the floors and the CPU's speed.

    Parameters
    ----------
    facts : dict[str, Any]
        ``probe_all``'s result.
    measured : Sequence[dict[str, Any]]
        ``floors``'s result.
    steady : dict[str, Any] | None, optional
        ``rig.bench.steadiness.cpu_steadiness``'s result (None: not measured).

    Returns
    -------
    list[dict[str, str]]
        What to change: ``setting`` and why.
    """
    found = [
        *_kernel(facts["kernel"]),
        *_cpuidle(facts["cpuidle"], facts["granted"]),
        *_grants(facts["granted"]),
        *_throttling(facts["throttling"]),
        *_governor(facts["cpufreq"]),
        *_isolation(facts["isolation"]),
        *_hypervisor(facts["hypervisor"], measured),
        *_speed(facts["hypervisor"], steady),
        *_socketcan(facts["can"]),
    ]
    return [{"setting": setting, "now": now, "change": change} for setting, now, change in found]


def _kernel(k: dict[str, Any]) -> Iterator[Advice]:
    if k["preemption"] != "PREEMPT_RT":
        mode = f" ({k['mode']})" if k["mode"] else ""
        yield (
            "kernel preemption",
            f"{k['preemption']}{mode}",
            "a PREEMPT_RT kernel bounds the wake-up latency (Debian: linux-image-rt-amd64); with "
            "PREEMPT_DYNAMIC, boot with preempt=full at least",
        )


def _cpuidle(idle: dict[str, Any], g: dict[str, Any]) -> Iterator[Advice]:
    slow = [s for s in idle["states"] if s["exit_latency_us"] > 0 and not s["disabled"]]
    if not slow:
        return
    poll = (idle.get("haltpoll") or {}).get("guest_halt_poll_ns")
    names = ", ".join(f"{s['name']} ({s['exit_latency_us']} us)" for s in slow)
    halted = f"; haltpoll.guest_halt_poll_ns = {poll}" if poll is not None else ""
    if idle["driver"] == "haltpoll" and poll == "0":
        halted += " (an idle vCPU halts, and its wake-up is a VM exit)"
    if g["pm_qos"]:
        yield (
            "cpuidle",
            f"{idle['driver']}: {names}{halted}",
            "keep [run] rt_cpu_latency = 0 (and rig emulate --rt-cpu-latency 0, the default): the run "
            f"holds {g['pm_qos_device']} and the CPUs stay out of these states",
        )
    else:
        yield (
            "cpuidle",
            f"{idle['driver']}: {names}{halted}; PM QoS refused: {g['pm_qos_refused']}",
            f"give the run write access to {g['pm_qos_device']} (root), or boot with "
            "idle=poll or haltpoll.guest_halt_poll_ns=200000",
        )


def _grants(g: dict[str, Any]) -> Iterator[Advice]:
    if not g["sched_fifo"]:
        yield (
            "SCHED_FIFO",
            f"refused ({g['sched_fifo_refused']}; RLIMIT_RTPRIO {g['limits'].get('RLIMIT_RTPRIO')})",
            "run as root, or give CAP_SYS_NICE, or raise rtprio (ulimit -r 99; limits.conf rtprio 99)",
        )
    if not g["mlockall"]:
        yield (
            "mlockall",
            f"refused ({g['mlockall_refused']}; RLIMIT_MEMLOCK {g['limits'].get('RLIMIT_MEMLOCK')})",
            "run as root, or give CAP_IPC_LOCK, or raise memlock (ulimit -l unlimited)",
        )


def _throttling(t: dict[str, Any]) -> Iterator[Advice]:
    if t["runtime_us"] is not None and t["runtime_us"] >= 0 and t["period_us"]:
        if t["runtime_us"] / t["period_us"] < 0.9:
            yield (
                "real-time throttling",
                f"{t['runtime_us']} of {t['period_us']} us",
                "real-time threads get at most that share of each period: raise "
                "/proc/sys/kernel/sched_rt_runtime_us to 950000 (the kernel's default)",
            )


def _governor(cpufreq: dict[str, Any]) -> Iterator[Advice]:
    slowgov = {cpu: gov for cpu, gov in cpufreq["governors"].items() if gov != "performance"}
    if slowgov:
        yield (
            "CPU frequency governor",
            ", ".join(f"{cpu} {gov}" for cpu, gov in slowgov.items()),
            "cpupower frequency-set -g performance (a governor that lowers the clock lengthens every cycle)",
        )


def _isolation(iso: dict[str, Any]) -> Iterator[Advice]:
    if (iso["cpus"] or 1) >= 2 and not iso["isolated"]:
        last = (iso["cpus"] or 2) - 1
        yield (
            "isolated CPUs",
            "none",
            f"boot with isolcpus={last} nohz_full={last} rcu_nocbs={last}, and keep [run] rt_cpu = -1 (the "
            "last CPU): nothing else is then scheduled where the loop runs",
        )


def _hypervisor(hypervisor: dict[str, Any], measured: Sequence[dict[str, Any]]) -> Iterator[Advice]:
    stolen = [m["with_pm_qos"].get("cpu_stolen_s") or 0.0 for m in measured]
    if hypervisor["virtual"] and any(x > 0 for x in stolen):
        yield (
            "hypervisor",
            f"took {1e3 * max(stolen):.0f} ms of CPU time during a floor measurement",
            "ask the virtual machine's host for dedicated (pinned) vCPUs, or run the rig on bare metal: "
            "no setting inside the machine prevents steal",
        )


def _speed(hypervisor: dict[str, Any], steady: dict[str, Any] | None) -> Iterator[Advice]:
    if steady is None or not steady["slow_share"] > UNSTEADY:
        return
    now = described(steady)
    if hypervisor["virtual"]:
        change = (
            "ask the virtual machine's host for dedicated physical cores (no SMT sibling shared with another "
            "machine, a fixed frequency), or run the rig on bare metal: nothing inside the machine shows or "
            "changes it, and a cycle that falls in such a run takes 1.5 times as long or more whatever the "
            "loop does"
        )
    else:
        change = (
            "fix the CPU's frequency (governor performance, no turbo) and keep the loop's CPU's SMT sibling "
            "idle (nosmt, or isolate both): a cycle that falls in such a run takes 1.5 times as long or more"
        )
    yield "CPU speed", now, change


def _socketcan(c: dict[str, Any]) -> Iterator[Advice]:
    if not c["socketcan"]:
        yield (
            "SocketCAN",
            f"not in this kernel ({c['socketcan_refused']})",
            "reach drives through socketcand (rig emulate serves it; a CAN adapter's server elsewhere), or "
            "use a kernel with CAN (can, can-raw, vcan) for SocketCAN and the vcan tier",
        )
