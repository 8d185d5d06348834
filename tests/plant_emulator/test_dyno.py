"""The dyno preset: motor under test, encoder and load machine on one shaft, with canopen's own
RemoteNode (SDO, PDO) as the client and the expected motion computed here from (3.4)."""

from __future__ import annotations

import math
import struct
from collections import defaultdict
from collections.abc import Iterator, Sequence

import canopen
import numpy as np
import pytest
import scipy.linalg
from canopen.sdo import SdoAbortedError

from drivers.maps import CIA402_EDS, CIA406_EDS
from plant_emulator.cia402_drive import EmulatedDrive
from plant_emulator.lockstep import SyncHub, attach_network
from plant_emulator.presets import build_preset

CPR = 4096  #: increments per revolution (the preset's default)
T = 0.4e-3  #: SYNC period [s]
# the dc-servo preset's DC motor, from its documented a_m, b_m (section VII.B), R_r, tau_e
A_M, B_M, R_R, TAU_E = 16.0, 680.0, 1.0, 1e-4
K = A_M / B_M  # k_e = k_t [V s/rad]
J_M = K / (R_R * B_M)  # [kg m^2]


class Dyno:
    """The dyno on an in-process bus, its nodes booted (and so handling SYNC) in ``order``; the
    motor without friction unless ``params`` give it (the motion expected here is (3.4) with
    B = 0 and no Coulomb friction: these tests are about the shaft's coupling)."""

    def __init__(self, order: Sequence[int] = (0, 1, 2), **params: object) -> None:
        self.hub = SyncHub()
        net, self.host = canopen.Network(), canopen.Network()
        attach_network(net, self.hub.bus(queue=False, channel="emulator"))
        attach_network(self.host, self.hub.bus(queue=False, channel="host"))
        params = {"friction": 0.0, "coulomb": 0.0, **params}
        self.devices, self.period = build_preset("dyno", net, params)
        for i in order:
            self.devices[i].boot()
        self.frames: dict[int, list[bytes]] = defaultdict(list)
        self.host.bus.listeners.append(lambda m: self.frames[m.arbitration_id].append(bytes(m.data)))
        self.motor = canopen.RemoteNode(1, CIA402_EDS)
        self.encoder = canopen.RemoteNode(2, CIA406_EDS)
        self.load = canopen.RemoteNode(3, CIA402_EDS)
        for node in (self.motor, self.encoder, self.load):
            self.host.add_node(node)
        self.syncs = 0

    def sync(self) -> None:
        self.syncs += 1
        self.hub.clock = self.syncs * self.period
        self.host.send_message(0x80, b"")

    def start(self, *, motor_mode: int = -1) -> None:
        """NMT start all; both drives to OPERATION ENABLED by SDO; the RPDO maps read."""
        self.host.send_message(0, bytes([0x01, 0]))
        self.motor.sdo[0x6060].raw = motor_mode
        for node in (self.motor, self.load):
            for cw in (0x06, 0x0F):
                node.sdo[0x6040].raw = cw
            node.rpdo.read()

    def volts(self, u: float) -> None:
        """Armature voltage [V] over the motor's RPDO1 (controlword, 0x2100 [mV])."""
        pdo = self.motor.rpdo[1]
        pdo["Controlword"].raw = 0x0F
        pdo["Target voltage mV"].raw = round(u * 1000)
        pdo.transmit()

    def load_torque(self, permille: int, *, cw: int = 0x0F) -> None:
        """The load machine's torque [per mille of its 0x6076] over its RPDO4, with controlword ``cw``."""
        pdo = self.load.rpdo[4]
        pdo["Controlword"].raw = cw
        pdo["Target torque"].raw = permille
        pdo["Modes of operation"].raw = 10
        pdo.transmit()

    def tpdo(self, cob: int, fmt: str) -> list[tuple[int, ...]]:
        return [struct.unpack(fmt, d) for d in self.frames[cob]]

    @property
    def drive(self) -> EmulatedDrive:
        d = self.devices[0]
        assert isinstance(d, EmulatedDrive)
        return d

    def close(self) -> None:
        for net in (self.host, self.devices[0].network):
            net.bus.shutdown()


@pytest.fixture
def dyno() -> Iterator[Dyno]:
    d = Dyno()
    yield d
    d.close()


def dc_motion(u: float, torques: Sequence[tuple[float, float]], times: np.ndarray, j: float) -> np.ndarray:
    """[theta, omega, i_r] of (3.4) at ``times`` [s] from rest, with u [V] and the load machine's
    torque T_lm [N m] = torques[n][1] from torques[n][0] on (T_L = -T_lm, B = 0), by the matrix
    exponential of the system augmented with its constant input (exact for inputs held piecewise)."""
    l_r = TAU_E * R_R
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, K / j], [0.0, -K / l_r, -R_R / l_r]])

    def flow(x0: np.ndarray, t_lm: float, tau: float) -> np.ndarray:
        M = np.zeros((4, 4))
        M[:3, :3], M[:3, 3] = A, [0.0, t_lm / j, u / l_r]
        E = scipy.linalg.expm(M * tau)
        return np.asarray(E[:3, :3] @ x0 + E[:3, 3])

    out = []
    for t in times:
        x = np.zeros(3)
        for n, (start, t_lm) in enumerate(torques):
            end = torques[n + 1][0] if n + 1 < len(torques) else math.inf
            x = flow(x, t_lm, min(t, end) - start)
            if t < end:
                break
        out.append(x)
    return np.array(out)


def test_constant_voltage_against_a_counter_torque_follows_the_shaft_equation() -> None:
    """J dw/dt = k_t i - T_L with J = J_m + j_load and T_L = -T_lm; T_lm changes after 0.1 s."""
    j_load = 2e-5
    d = Dyno(j_load=j_load)
    d.start()
    rated = d.load.sdo[0x6076].raw / 1000.0  # N m
    d.volts(6.0)
    d.load_torque(-400)  # synchronous RPDOs, sent before SYNC 1: in force from t_1 on
    for k in range(1, 501):
        d.sync()
        if k == 250:
            d.load_torque(-200)  # in force from SYNC 251 on
    times = T * np.arange(500)  # SYNC k at t_1 + (k - 1) T
    x = dc_motion(6.0, [(0.0, -0.4 * rated), (250 * T, -0.2 * rated)], times, J_M + j_load)
    axis = d.drive.axis
    assert axis.velocity == pytest.approx(x[-1, 1], rel=1e-9)
    assert axis.position == pytest.approx(x[-1, 0], rel=1e-9)
    wire = d.tpdo(0x281, "<ii")  # position [increments], velocity [increments/s] at each SYNC
    assert len(wire) == 500
    counts_per_rad = CPR / (2 * math.pi)
    for (pos, vel), (theta, omega, _) in zip(wire, x):
        assert abs(pos - math.floor(theta * counts_per_rad)) <= 1
        assert abs(vel - round(omega * counts_per_rad)) <= 1
    torque = d.tpdo(0x383, "<Hhh")  # the load machine's statusword, torque, current [per mille]
    assert torque[100][1:] == (-400, -400) and torque[-1][1:] == (-200, -200)
    assert torque[100][0] & 0x6F == 0x27  # OPERATION ENABLED
    d.close()


def test_disabled_load_machine_gives_no_torque(dyno: Dyno) -> None:
    dyno.start()
    dyno.load.sdo[0x6040].raw = 0x06  # shutdown: READY TO SWITCH ON, power stage off
    dyno.volts(6.0)
    dyno.load_torque(-400, cw=0x06)  # commanded, but the power stage is off
    for _ in range(300):
        dyno.sync()
    x = dc_motion(6.0, [(0.0, 0.0)], T * np.arange(300), J_M)
    assert dyno.drive.axis.velocity == pytest.approx(x[-1, 1], rel=1e-9)
    statusword, torque, current = dyno.tpdo(0x383, "<Hhh")[-1]
    assert (statusword & 0x6F, torque, current) == (0x21, 0, 0)
    # enabled again, then disabled mid-run: the torque stops at the SYNC after the disable
    for cw in (0x06, 0x0F):
        dyno.load.sdo[0x6040].raw = cw
    dyno.load_torque(-400)
    for _ in range(5):
        dyno.sync()
    assert dyno.tpdo(0x383, "<Hhh")[-1][1] == -400
    dyno.load.sdo[0x6040].raw = 0x00  # disable voltage
    dyno.sync()
    assert dyno.tpdo(0x383, "<Hhh")[-1][1:] == (0, 0)


def _scripted_run(order: Sequence[int]) -> tuple[list[tuple[float, float, float]], dict[int, list[bytes]]]:
    """A sine voltage over a synchronous RPDO and a load torque over an event RPDO applied
    100 us after receipt, so each period has commands at two instants."""
    d = Dyno(order)
    d.start()
    d.load.sdo[0x2001].raw = 100  # us
    d.load.rpdo[4].trans_type = 255
    d.load.rpdo[4].save()
    states = []
    for k in range(400):
        d.volts(6.0 + 3.0 * math.sin(2 * math.pi * 25 * k * T))
        d.load_torque(round(-300 + 200 * math.cos(2 * math.pi * 40 * k * T)))
        d.sync()
        axis = d.drive.axis
        states.append((axis.position, axis.velocity, axis.current))
    d.close()
    return states, dict(d.frames)


def test_node_order_does_not_change_the_result() -> None:
    base_states, base_frames = _scripted_run((0, 1, 2))
    assert base_states[-1][1] > 10.0  # it moved
    for order in ((2, 1, 0), (1, 2, 0), (2, 0, 1)):
        states, frames = _scripted_run(order)
        assert np.allclose(states, base_states, rtol=1e-12, atol=1e-12), order
        for cob in (0x281, 0x381, 0x282, 0x283, 0x383):  # TPDOs of all three nodes
            assert frames[cob] == base_frames[cob], (order, hex(cob))


@pytest.mark.parametrize("order", [(0, 1, 2), (1, 2, 0)])
def test_encoder_reads_the_drives_angle(order: Sequence[int]) -> None:
    d = Dyno(order)
    d.start()
    d.volts(6.0)
    d.load_torque(-300)
    for _ in range(600):
        d.sync()
    drive = d.tpdo(0x281, "<ii")
    encoder = d.tpdo(0x282, "<Ih")  # position [increments], speed [increments/s]
    assert len(drive) == len(encoder) == 600 and drive[-1][0] > CPR
    for (pos, _), (enc, _) in zip(drive, encoder):
        assert abs(pos - enc) <= 1  # to the quantum (the same floor of the same shaft angle)
    assert abs(d.encoder.sdo[0x6004].raw - d.motor.sdo[0x6064].raw) <= 1
    d.close()


def test_all_three_nodes_answer_sdo_and_send_heartbeats(dyno: Dyno) -> None:
    assert [d.node_id for d in dyno.devices] == [1, 2, 3]  # device 0: the motor under test
    assert [type(d).__name__ for d in dyno.devices] == ["EmulatedDrive", "EmulatedEncoder", "EmulatedDrive"]
    assert dyno.motor.sdo[0x1000].raw == 0x00020192
    assert dyno.encoder.sdo[0x1000].raw & 0xFFFF == 406
    assert dyno.load.sdo[0x1000].raw == 0x00020192
    assert dyno.motor.sdo[0x6502].raw == (1 << 16) | (1 << 9) | (1 << 8) | (1 << 7) | (1 << 2)
    assert dyno.load.sdo[0x6502].raw == 1 << 9  # CST only
    assert dyno.load.sdo[0x6061].raw == 10
    with pytest.raises(SdoAbortedError) as exc:
        dyno.load.sdo[0x6060].raw = 9  # CSV: not supported
    assert exc.value.code == 0x06090030
    for _ in range(251):  # 100 ms heartbeats
        dyno.sync()
    for cob in (0x701, 0x702, 0x703):
        assert dyno.frames[cob][-1] == b"\x7f", hex(cob)


def test_nmt_reset_of_one_drive_leaves_the_shaft_turning(dyno: Dyno) -> None:
    dyno.start()
    dyno.volts(6.0)
    for _ in range(200):
        dyno.sync()
    speed = dyno.drive.axis.velocity
    position = dyno.motor.sdo[0x6064].raw
    assert speed > 50.0
    dyno.host.send_message(0, bytes([0x81, 3]))  # reset the load machine's drive
    assert dyno.frames[0x703][-1] == b"\x00"  # its boot-up
    dyno.sync()
    assert dyno.motor.sdo[0x6064].raw > position  # no jump back to zero
    assert dyno.drive.axis.velocity == pytest.approx(speed, rel=0.01)
    assert dyno.load.sdo[0x6041].raw & 0x4F == 0x40  # SWITCH ON DISABLED
    dyno.host.send_message(0, bytes([0x81, 1]))  # reset the motor's drive: the motor coasts on
    dyno.sync()
    assert dyno.drive.axis.velocity == pytest.approx(speed, rel=0.02)
    assert dyno.encoder.sdo[0x6004].raw >= position


def test_induction_motor_under_test_against_the_load_machine() -> None:
    """motor=im: after 0.6 s of magnetising (T_r = 0.14 s), 2 N m against -1 N m gives
    J dw/dt = 1 - B w (Table II)."""
    d = Dyno(motor="im")
    d.start(motor_mode=10)
    rated = d.motor.sdo[0x6076].raw / 1000.0
    assert rated == d.load.sdo[0x6076].raw / 1000.0 == 5.0
    torque = d.motor.rpdo[4]
    torque["Controlword"].raw = 0x0F
    torque["Modes of operation"].raw = 10
    for k in range(1, 2251):  # 0.9 s
        if k == 1500:
            torque["Target torque"].raw = round(2.0 / rated * 1000)
            torque.transmit()
            d.load_torque(round(-1.0 / rated * 1000))
        d.sync()
    j, b, t = 0.0035, 0.0022, 750 * T  # Table II
    expected = (1.0 / b) * (1.0 - math.exp(-b * t / j))
    assert d.drive.axis.velocity == pytest.approx(expected, rel=0.05)
    assert d.tpdo(0x383, "<Hhh")[-1][1] == -200
    d.close()


def test_load_machine_torque_lag_drives_a_coasting_motor() -> None:
    """load_torque_lag tau: T_lm = T (1 - e^(-t/tau)); with the motor's drive off (armature open,
    B = 0) J dw/dt = T_lm, so w = (T/J) (t - tau (1 - e^(-t/tau)))."""
    tau = 2e-3
    d = Dyno(load_torque_lag=tau)
    d.host.send_message(0, bytes([0x01, 0]))
    d.load.rpdo.read()
    for cw in (0x06, 0x0F):
        d.load.sdo[0x6040].raw = cw
    rated = d.load.sdo[0x6076].raw / 1000.0
    d.load_torque(400)  # in force from SYNC 1 on
    for _ in range(101):
        d.sync()
    torque = 0.4 * rated
    wire = d.tpdo(0x383, "<Hhh")
    for k, (_, permille, _) in enumerate(wire):
        assert abs(permille - 400 * (1 - math.exp(-k * T / tau))) <= 1, k
    t = 100 * T
    expected = torque / J_M * (t - tau * (1 - math.exp(-t / tau)))
    assert d.drive.axis.velocity == pytest.approx(expected, rel=1e-9)
    d.close()
