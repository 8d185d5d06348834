"""``rig doctor``: the verdict per period from a floor, the advice naming each setting from what the
probes read, and the command's JSON document (a short floor: its figures are the machine's, only
their presence is checked)."""

from __future__ import annotations

import json
from typing import Any

import pytest

from rig.bench.steadiness import SLOW, slow_episodes
from rig.cli import main
from rig.doctor.verdict import UNSTEADY, advice, verdicts


def _floor(missed: int, p99_us: float, periods: int = 10_000) -> dict[str, Any]:
    return {
        "periods": periods,
        "missed": missed,
        "missed_share": missed / periods,
        "lateness_us": {"median": 5.0, "p99": p99_us, "max": 10 * p99_us},
        "cpu_stolen_s": 0.01,
        "granted": "SCHED_FIFO 50",
    }


@pytest.mark.parametrize(
    ("missed", "p99_us", "verdict"),
    [(10, 100.0, "kept"), (11, 100.0, "marginal"), (10, 101.0, "marginal"), (100, 200.0, "marginal"),
     (101, 200.0, "not kept"), (100, 201.0, "not kept")],
)  # fmt: skip
def test_a_period_s_verdict_sits_at_its_thresholds(missed: int, p99_us: float, verdict: str) -> None:
    """At 0.4 ms: kept to 0.1 % missed and a quarter period (100 us) late at p99; marginal to 1 %
    and half a period; beyond, not kept."""
    (v,) = verdicts(
        [{"period_s": 0.0004, "with_pm_qos": _floor(missed, p99_us), "without_pm_qos": _floor(0, 0)}]
    )
    assert v["verdict"] == verdict and v["without_pm_qos"] == "kept"


FACTS = {
    "kernel": {"preemption": "PREEMPT_DYNAMIC", "mode": None},
    "cpuidle": {
        "driver": "haltpoll",
        "states": [{"name": "POLL", "exit_latency_us": 0, "disabled": False},
                   {"name": "haltpoll idle", "exit_latency_us": 1, "disabled": False}],
        "haltpoll": {"guest_halt_poll_ns": "0"},
    },
    "granted": {"sched_fifo": True, "mlockall": True, "pm_qos": True, "pm_qos_device": "/dev/cpu_dma_latency",
                "limits": {}},
    "throttling": {"runtime_us": 950000, "period_us": 1000000},
    "cpufreq": {"governors": {"cpu0": "powersave"}},
    "isolation": {"cpus": 2, "isolated": "", "nohz_full": ""},
    "hypervisor": {"virtual": True},
    "can": {"socketcan": False, "socketcan_refused": "Address family not supported by protocol"},
}  # fmt: skip


def test_the_advice_names_each_setting_to_change() -> None:
    measured = [{"period_s": 0.001, "with_pm_qos": _floor(0, 50.0), "without_pm_qos": _floor(5, 300.0)}]
    said = {a["setting"]: a for a in advice(FACTS, measured)}
    assert set(said) == {
        "kernel preemption", "cpuidle", "CPU frequency governor", "isolated CPUs", "hypervisor", "SocketCAN",
    }  # fmt: skip
    assert "rt_cpu_latency = 0" in said["cpuidle"]["change"] and "VM exit" in said["cpuidle"]["now"]
    assert "isolcpus=1 nohz_full=1" in said["isolated CPUs"]["change"]
    refused = json.loads(json.dumps(FACTS))
    refused["granted"] |= {"pm_qos": False, "pm_qos_refused": "Permission denied", "sched_fifo": False,
                           "sched_fifo_refused": "Operation not permitted"}  # fmt: skip
    refused["throttling"] = {"runtime_us": 500000, "period_us": 1000000}
    said = {a["setting"]: a for a in advice(refused, measured)}
    assert "PM QoS refused: Permission denied" in said["cpuidle"]["now"] and "SCHED_FIFO" in said
    assert "950000" in said["real-time throttling"]["change"]


def test_rig_doctor_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["doctor", "--period", "0.01", "--seconds", "0.05", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) >= {
        "kernel", "cpuidle", "granted", "throttling", "cpufreq", "isolation", "hypervisor", "can",
        "floor", "cpu_steadiness", "verdicts", "advice",
    }  # fmt: skip
    assert doc["cpu_steadiness"]["calls"] == 5 and doc["cpu_steadiness"]["work_us"]["median"] > 0
    (floor,) = doc["floor"]
    assert floor["period_s"] == 0.01 and floor["with_pm_qos"]["periods"] == 5
    assert doc["verdicts"][0]["verdict"] in ("kept", "marginal", "not kept")


def test_rig_doctor_refuses_a_bad_period(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["doctor", "--period", "0"]) == 2
    assert "--period: must be in (0, 1] s, got 0" in capsys.readouterr().err


def test_slow_episodes_counts_the_runs_of_slow_periods() -> None:
    """Periods whose work took SLOW times the median or more: their share, how often one follows
    another, and the longest run in periods' time; a run at exactly SLOW times counts."""
    durations = [10e-6] * 90 + [SLOW * 10e-6] * 6 + [10e-6] * 2 + [30e-6] * 2
    s = slow_episodes(durations, 0.0004)
    assert s["calls"] == 100 and s["work_us"]["median"] == pytest.approx(10.0)
    assert s["slow_share"] == pytest.approx(0.08) and s["longest_slow_ms"] == pytest.approx(6 * 0.4)
    assert s["slow_after_slow"] == pytest.approx(6 / 7)  # 7 slow calls with a successor, 6 of them slow
    steady = slow_episodes([10e-6] * 50, 0.001)
    assert steady["slow_share"] == 0 and steady["longest_slow_ms"] == 0
    empty = slow_episodes([], 0.001)  # no period measured: NaN, not 0
    assert empty["calls"] == 0 and empty["slow_share"] != empty["slow_share"]


def test_an_unsteady_cpu_gets_a_line_naming_it() -> None:
    """Beyond UNSTEADY slow periods the advice names the CPU's speed (a virtual machine's: its host's
    dedicated cores); at UNSTEADY, nothing."""
    measured = [{"period_s": 0.001, "with_pm_qos": _floor(0, 50.0), "without_pm_qos": _floor(0, 50.0)}]
    calm = slow_episodes([10e-6] * 1000, 0.0004)
    unsteady = calm | {"slow_share": UNSTEADY + 1e-3, "longest_slow_ms": 90.0}
    assert "CPU speed" not in {a["setting"] for a in advice(FACTS, measured, calm | {"slow_share": UNSTEADY})}
    said = {a["setting"]: a for a in advice(FACTS, measured, unsteady)}
    assert "1.1 % of 1000 periods (p99 10 us), in runs of up to 90 ms" in said["CPU speed"]["now"]
    assert "dedicated physical cores" in said["CPU speed"]["change"]
    bare = json.loads(json.dumps(FACTS)) | {"hypervisor": {"virtual": False}}
    assert "nosmt" in {a["setting"]: a for a in advice(bare, measured, unsteady)}["CPU speed"]["change"]
