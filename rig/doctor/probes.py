"""What this PC gives a real-time loop, read from the kernel (``rig doctor``): each probe reads files
of /proc and /sys, or asks for a measure and gives it back at once, and returns plain data.

- ``kernel``: the preemption model (PREEMPT_RT, a dynamic one and its mode where debugfs shows it,
  or none), the kernel command line's settings that matter to real time;
- ``cpuidle``: the idle driver, governor, states (exit latency, disabled) and haltpoll's guest
  halt polling;
- ``granted``: whether this process may have SCHED_FIFO, mlockall and a PM QoS CPU latency
  request (each asked for and given back), with the limits behind a refusal (RLIMIT_RTPRIO,
  RLIMIT_MEMLOCK);
- ``throttling``: the kernel's real-time throttling (sched_rt_runtime_us of sched_rt_period_us);
- ``cpufreq``: each CPU's frequency governor (none on most virtual machines);
- ``isolation``: isolated CPUs (isolcpus), nohz_full, rcu_nocbs;
- ``hypervisor``: whether the CPU says it runs under one, and the steal time since boot;
- ``can``: SocketCAN in the kernel (a CAN_RAW socket), CAN interfaces and vcan ones.

A file that is missing says so (None), never an error: the probe describes, the verdict judges.
"""

from __future__ import annotations

import contextlib
import os
import re
import resource
import socket
import threading
from pathlib import Path
from typing import Any

from rig.host.realtime import CPU_DMA_LATENCY, RealtimeRequest, cpu_stolen, request

__all__ = [
    "can",
    "cpufreq",
    "cpuidle",
    "granted",
    "hypervisor",
    "isolation",
    "kernel",
    "probe_all",
    "throttling",
]

SYS_CPU = Path("/sys/devices/system/cpu")
_CMDLINE_KEYS = (
    "preempt",
    "isolcpus",
    "nohz_full",
    "rcu_nocbs",
    "idle",
    "cpuidle_haltpoll.force",
    "haltpoll.guest_halt_poll_ns",
    "intel_idle.max_cstate",
    "processor.max_cstate",
    "threadirqs",
    "skew_tick",
    "nosmt",
)


def _read(path: str | Path) -> str | None:
    try:
        return Path(path).read_text(encoding="ascii", errors="replace").strip()
    except OSError:
        return None


def _cmdline() -> dict[str, str]:
    """The kernel command line's settings of ``_CMDLINE_KEYS`` (a flag alone: "")."""
    out: dict[str, str] = {}
    for word in (_read("/proc/cmdline") or "").split():
        key, _, value = word.partition("=")
        if key in _CMDLINE_KEYS:
            out[key] = value
    return out


def kernel() -> dict[str, Any]:
    """The kernel's release, its preemption model and the command line's real-time settings.

    Returns
    -------
    dict[str, Any]
        ``release``, ``preemption`` and the command line's settings.
    """
    version = os.uname().version
    model = "PREEMPT_RT" if "PREEMPT_RT" in version or _read("/sys/kernel/realtime") == "1" else None
    if model is None:
        model = next((m for m in ("PREEMPT_DYNAMIC", "PREEMPT") if m in version), "none (server)")
    mode = None
    debug = _read("/sys/kernel/debug/sched/preempt")
    if debug:
        found = re.search(r"\((\w+)\)", debug)
        mode = found.group(1) if found else debug
    cmdline = _cmdline()
    if mode is None and "preempt" in cmdline:
        mode = cmdline["preempt"]
    return {
        "release": os.uname().release,
        "version": version,
        "preemption": model,
        "mode": mode,
        "cmdline": cmdline,
    }


def cpuidle() -> dict[str, Any]:
    """The idle driver and governor, cpu0's states, and haltpoll's guest halt polling.

    Returns
    -------
    dict[str, Any]
        The driver, governor, states and halt polling.
    """
    states = []
    for state in sorted((SYS_CPU / "cpu0" / "cpuidle").glob("state*")):
        states.append(
            {
                "name": _read(state / "name"),
                "exit_latency_us": int(_read(state / "latency") or 0),
                "disabled": _read(state / "disable") == "1",
            }
        )
    params = Path("/sys/module/haltpoll/parameters")
    haltpoll = {p.name: _read(p) for p in sorted(params.glob("*"))} if params.is_dir() else None
    return {
        "driver": _read(SYS_CPU / "cpuidle" / "current_driver"),
        "governor": _read(SYS_CPU / "cpuidle" / "current_governor")
        or _read(SYS_CPU / "cpuidle" / "current_governor_ro"),
        "states": states,
        "haltpoll": haltpoll,
    }


def _try_fifo() -> str | None:
    """None where a thread may have SCHED_FIFO 1 (asked in a thread of its own), else why not."""
    said: list[str | None] = [None]

    def ask() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        except (OSError, AttributeError) as exc:
            said[0] = str(getattr(exc, "strerror", None) or exc)

    t = threading.Thread(target=ask, name="rig-doctor-fifo")
    t.start()
    t.join()
    return said[0]


def _why(refused: list[str], what: str) -> str:
    return next((r for r in refused if what in r), "refused")


def granted() -> dict[str, Any]:
    """Each real-time measure asked for and given back: SCHED_FIFO, mlockall, PM QoS.

    Returns
    -------
    dict[str, Any]
        Each measure and what was given.
    """
    fifo = _try_fifo() if hasattr(os, "sched_setscheduler") else "not available on this system"
    grant = request(RealtimeRequest(priority=0, cpu=-2, lock_memory=True, cpu_latency=0))
    try:
        memory = None if grant.memory_locked else next((r for r in grant.refused if "memory" in r), "refused")
        qos = (
            None
            if grant.cpu_latency is not None
            else next((r for r in grant.refused if "PM QoS" in r), "refused")
        )
    finally:
        grant.release()
    limits = {}
    for name in ("RLIMIT_RTPRIO", "RLIMIT_MEMLOCK"):
        with contextlib.suppress(AttributeError, ValueError, OSError):
            soft, _hard = resource.getrlimit(getattr(resource, name))
            limits[name] = "unlimited" if soft == resource.RLIM_INFINITY else soft
    return {
        "sched_fifo": fifo is None,
        "sched_fifo_refused": fifo,
        "mlockall": memory is None,
        "mlockall_refused": memory,
        "pm_qos": qos is None,
        "pm_qos_refused": qos,
        "pm_qos_device": CPU_DMA_LATENCY,
        "limits": limits,
        "root": os.geteuid() == 0 if hasattr(os, "geteuid") else None,
    }


def throttling() -> dict[str, Any]:
    """The kernel's real-time throttling: runtime of period [us] (-1: none).

    Returns
    -------
    dict[str, Any]
        ``runtime_us`` and ``period_us``.
    """
    runtime = _read("/proc/sys/kernel/sched_rt_runtime_us")
    period = _read("/proc/sys/kernel/sched_rt_period_us")
    return {
        "runtime_us": int(runtime) if runtime is not None else None,
        "period_us": int(period) if period is not None else None,
    }


def cpufreq() -> dict[str, Any]:
    """Each CPU's frequency governor (an empty mapping where the kernel has no cpufreq here).

    Returns
    -------
    dict[str, Any]
        CPU -> governor.
    """
    out = {}
    for cpu in sorted(SYS_CPU.glob("cpu[0-9]*")):
        governor = _read(cpu / "cpufreq" / "scaling_governor")
        if governor is not None:
            out[cpu.name] = governor
    return {"governors": out}


def isolation() -> dict[str, Any]:
    """Isolated CPUs (isolcpus), nohz_full and rcu_nocbs: the kernel's files and command line.

    Returns
    -------
    dict[str, Any]
        The kernel's files and command line.
    """
    cmd = _cmdline()
    return {
        "cpus": os.cpu_count(),
        "isolated": _read(SYS_CPU / "isolated") or "",
        "nohz_full": _read(SYS_CPU / "nohz_full") or cmd.get("nohz_full", ""),
        "rcu_nocbs": cmd.get("rcu_nocbs", ""),
    }


def hypervisor() -> dict[str, Any]:
    """Whether the CPU reports a hypervisor, and the steal time since boot [s].

    Returns
    -------
    dict[str, Any]
        ``hypervisor`` and ``steal_s``.
    """
    flags = ""
    for line in (_read("/proc/cpuinfo") or "").splitlines():
        if line.startswith("flags"):
            flags = line
            break
    return {
        "virtual": " hypervisor" in flags,
        "type": _read("/sys/hypervisor/type"),
        "stolen_since_boot_s": cpu_stolen(),
    }


def can() -> dict[str, Any]:
    """SocketCAN in the kernel (a CAN_RAW socket opens), the CAN interfaces and the vcan ones.

    Returns
    -------
    dict[str, Any]
        Whether CAN_RAW opens, the interfaces, the vcan ones.
    """
    try:
        with socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW):
            socketcan, why = True, None
    except (AttributeError, OSError) as exc:
        socketcan, why = False, str(getattr(exc, "strerror", None) or exc)
    interfaces, vcan = [], []
    for net in sorted(Path("/sys/class/net").glob("*")):
        if _read(net / "type") == "280":  # ARPHRD_CAN
            interfaces.append(net.name)
            if "vcan" in (_read(net / "uevent") or "") or net.name.startswith("vcan"):
                vcan.append(net.name)
    return {
        "socketcan": socketcan,
        "socketcan_refused": why,
        "interfaces": interfaces,
        "vcan": vcan,
        "vcan_module": Path("/sys/module/vcan").exists(),
    }


def probe_all() -> dict[str, Any]:
    """Every probe, by name.

    Returns
    -------
    dict[str, Any]
        Probe name -> its facts.
    """
    return {
        "kernel": kernel(),
        "cpuidle": cpuidle(),
        "granted": granted(),
        "throttling": throttling(),
        "cpufreq": cpufreq(),
        "isolation": isolation(),
        "hypervisor": hypervisor(),
        "can": can(),
    }
