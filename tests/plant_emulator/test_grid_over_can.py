"""The dq current controller over CAN against the emulated grid converter equals the pure simulation."""

from __future__ import annotations

import math

import canopen
import pytest

from controllers.dq_current import ComplexVectorCurrentController, DqCurrentParams
from drivers.maps import CIA402_EDS
from plant_emulator.lockstep import LockstepBench
from plant_emulator.rl_dq import RLParams, StationaryRLConverter

L1, R1, W = 6e-3, 0.36, 2 * math.pi * 50
TS = 1 / 1350


def _over_can(strategy: str, steps: int) -> list[complex]:
    bench = LockstepBench("grid-converter", {"strategy": strategy, "u_line_rms": 0.0})
    node = canopen.RemoteNode(1, CIA402_EDS)
    bench.host.add_node(node)
    node.tpdo.read()
    node.rpdo.read()
    node.nmt.state = "OPERATIONAL"
    for cw in (0x06, 0x0F):
        node.sdo[0x6040].raw = cw
    ctl = ComplexVectorCurrentController(DqCurrentParams(R1, L1, TS, 0.35, strategy))
    i_d, i_q = node.tpdo[4]["dq current mA.i_d"], node.tpdo[4]["dq current mA.i_q"]
    u_d, u_q = node.rpdo[1]["dq voltage reference mV.u_d"], node.rpdo[1]["dq voltage reference mV.u_q"]
    out = []
    for _ in range(steps):
        bench.sync()  # the drive steps its physics and its TPDOs arrive
        i = complex(i_d.raw, i_q.raw) / 1000.0
        out.append(i)
        u = ctl.step(10j, i, W)
        u_d.raw, u_q.raw = round(u.real * 1000), round(u.imag * 1000)
        node.rpdo[1].transmit()
    bench.close()
    return out


def _pure(strategy: str, steps: int) -> list[complex]:
    # the drive's latency object 0x2001 holds whole microseconds: T_s/2 = 370.37 us -> 370 us
    m = 1.0 - round(TS / 2 * 1e6) * 1e-6 / TS if strategy == "s-pwm-middle" else 0.0
    plant = StationaryRLConverter(RLParams(R1, L1, TS, m), u_max=700 / math.sqrt(3))
    ctl = ComplexVectorCurrentController(DqCurrentParams(R1, L1, TS, 0.35, strategy))
    i, out = 0j, []
    for _ in range(steps):
        q = complex(round(i.real * 1000), round(i.imag * 1000)) / 1000.0  # mA on the wire
        out.append(q)
        u = ctl.step(10j, q, W)
        i = plant.step(complex(round(u.real * 1000), round(u.imag * 1000)) / 1000.0, W)  # mV on the wire
    return out


@pytest.mark.parametrize("strategy", ["s-pwm-start", "s-pwm-middle"])
def test_current_control_over_can_matches_the_simulation(strategy: str) -> None:
    """Sync RPDO = one period of delay (s-PWM-start); event RPDO with 0x2001 = T_s/2 = s-PWM-middle."""
    wire, pure = _over_can(strategy, 40), _pure(strategy, 40)
    for a, b in zip(wire, pure):
        assert a == pytest.approx(b, abs=2e-3)  # within 2 mA (one wire quantum, twice)
    assert abs(wire[-1] - 10j) < 0.05
    # s-PWM-start decouples (|i_d| < 0.1 % of the step); s-PWM-middle keeps the complex zero -beta_1 of (38)
    assert max(abs(i.real) for i in wire) < (0.01 if strategy == "s-pwm-start" else 0.7)
