"""``rig run``: a configured control law over the wire, with safety and a recorder.

``run_config`` joins the pieces: the bus (or, with ``emulate``, the configured
preset on an in-process lock-step bus), the CiA 402 driver, the control law
from ``[controller]``, the limits and the recorder, and runs the host loop.

Control laws (``[controller] kind``):

- ``position-servo``: (7.30) with the design (7.31) from a_m, b_m, lam at the
  loop period; mode ``voltage``; reference ``smooth-move``. Parameters: a_m,
  b_m, lam, sigma, q, rho, h, u0.
- ``pi-speed``: a PI speed controller with anti-windup giving torque
  (mode ``cst``): kp [N m s/rad], ki [N m/rad], t_max [N m]; reference ``step``.
- ``idtsm-speed``: the integral DTSM (6.20)-(6.21) on the speed loop
  dw/dt = -(B/J) w + T/J (4.2) giving torque (mode ``cst``): j [kg m^2],
  friction [N m s/rad], lam [1/s], t_max [N m].
- ``cascade-position``: the position and speed loops of section VII.D
  (reconstructed (6.36), Table V) giving the q current, sent as torque k_t i_q
  (mode ``cst``): k_t [N m/A] (default b_w J of Table V), position_every.
- ``dq-current``: the complex-vector current controller (32)-(34), or (37) with
  ``middle = 1``, in mode ``dq-voltage``: r1, l1, gamma, f_line, u_max; the
  reference is i_q* [A] (``step``); the command column is |u|.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import canopen

from controllers.cascade import TABLE_V_POSITION, TABLE_V_SPEED, CascadeLoop
from controllers.design import design_dtsm
from controllers.dq_current import ComplexVectorCurrentController, DqCurrentParams
from controllers.idtsm import IDTSM, IDTSMParams
from controllers.pi import PI, PIParams
from controllers.position_servo import PositionServo, PositionServoParams
from drivers.bus import open_bus
from drivers.cia402 import Cia402Drive
from drivers.errors import CommunicationTimeout, ConfigError, SdoAbort
from drivers.maps import CIA402_EDS
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.faults import FaultInjector, FaultPlan
from plant_emulator.lockstep import SyncHub, attach_network
from plant_emulator.presets import build_preset
from rig.config import ControllerConfig, ReferenceConfig, RigConfig
from rig.emulate import preset_values
from rig.loop import Feedback, HostLoop, Law
from rig.recorder import Recorder
from rig.safety import Limits
from rig.scenarios import smooth_move

__all__ = ["CONTROLLERS", "Session", "build_law", "prepare", "reference_of", "run_config"]

log = logging.getLogger(__name__)


def reference_of(cfg: ReferenceConfig) -> Callable[[float], tuple[float, float]]:
    """(value, rate) of the reference at time t."""
    if cfg.kind == "smooth-move":
        return smooth_move(cfg.distance, cfg.duration, cfg.start)
    if cfg.kind == "step":
        return lambda t: (cfg.value if t >= cfg.start else 0.0, 0.0)
    if cfg.kind == "constant":
        return lambda t: (cfg.value, 0.0)
    raise ConfigError(f"[reference] kind = {cfg.kind!r}: expected smooth-move, step or constant")


def _params(cfg: ControllerConfig, defaults: dict[str, float], source: str) -> dict[str, float]:
    unknown = set(cfg.params) - set(defaults)
    if unknown:
        raise ConfigError(
            f"{source}: [controller] {cfg.kind}: unknown key(s) {sorted(unknown)}; known: {sorted(defaults)}"
        )
    return {**defaults, **cfg.params}


def _position_servo(cfg: RigConfig, period: float) -> tuple[Law, Sequence[str], str]:
    p = _params(
        cfg.controller,
        {
            "a_m": 16.0,
            "b_m": 680.0,
            "lam": -15.0,
            "sigma": 10.0,
            "q": 0.0,
            "rho": 0.5,
            "h": 16.0,
            "u0": math.inf,
        },
        cfg.source,
    )
    design = design_dtsm(A=[[0.0, 1.0], [0.0, -p["a_m"]]], b=[0.0, -p["b_m"]], dt=period, lam=p["lam"])
    ctl = PositionServo(
        PositionServoParams(design=design, sigma=p["sigma"], q=p["q"], rho=p["rho"], h=p["h"], u0=p["u0"])
    )
    ref = reference_of(cfg.reference)

    def law(t: float, fb: Feedback) -> tuple[float, float, float, Sequence[float]]:
        theta_r, omega_r = ref(t)
        u = ctl.step(theta_r - fb[0], omega_r - fb[1])
        return u, theta_r, fb[0], (ctl.g, ctl.u_i)

    return law, ("g", "u_i"), "voltage"


def _pi_speed(cfg: RigConfig, period: float) -> tuple[Law, Sequence[str], str]:
    p = _params(cfg.controller, {"kp": 0.1, "ki": 2.0, "t_max": math.inf}, cfg.source)
    ctl = PI(PIParams(kp=p["kp"], ki=p["ki"], dt=period, u_max=p["t_max"], u_min=-p["t_max"]))
    ref = reference_of(cfg.reference)

    def law(t: float, fb: Feedback) -> tuple[float, float, float, Sequence[float]]:
        w_r, _ = ref(t)
        torque = ctl.step(w_r - fb[1])
        return torque, w_r, fb[1], (ctl.integral,)

    return law, ("integral",), "cst"


def _idtsm_speed(cfg: RigConfig, period: float) -> tuple[Law, Sequence[str], str]:
    p = _params(
        cfg.controller, {"j": 0.0035, "friction": 0.0022, "lam": -50.0, "t_max": math.inf}, cfg.source
    )
    ctl = IDTSM(
        IDTSMParams(a=-p["friction"] / p["j"], b=1.0 / p["j"], dt=period, lam=p["lam"], u0=p["t_max"])
    )
    ref = reference_of(cfg.reference)

    def law(t: float, fb: Feedback) -> tuple[float, float, float, Sequence[float]]:
        w_r, _ = ref(t)
        torque = ctl.step(w_r - fb[1])
        return torque, w_r, fb[1], ()

    return law, (), "cst"


def _cascade_position(cfg: RigConfig, period: float) -> tuple[Law, Sequence[str], str]:
    """Section VII.D's position and speed loops (reconstructed (6.36), Table V) through CST:
    position every ``position_every`` SYNCs, speed every SYNC, i_q* -> torque = k_t i_q*."""
    p = _params(cfg.controller, {"k_t": 340.7439 * 0.0035, "position_every": 2.0}, cfg.source)
    position, speed = CascadeLoop(TABLE_V_POSITION), CascadeLoop(TABLE_V_SPEED)
    every = max(1, round(p["position_every"]))
    ref = reference_of(cfg.reference)
    state = {"k": 0, "omega_ref": 0.0}

    def law(t: float, fb: Feedback) -> tuple[float, float, float, Sequence[float]]:
        theta_r, _ = ref(t)
        if state["k"] % every == 0:
            state["omega_ref"] = position.step(theta_r, fb[0], fb[1])
        state["k"] += 1
        i_q = speed.step(state["omega_ref"], fb[1])
        return p["k_t"] * i_q, theta_r, fb[0], (state["omega_ref"], i_q)

    return law, ("omega_ref", "i_q_ref"), "cst"


class DqLink:
    """The host loop's drive for mode -2: scalar loop, complex process data.

    ``feedback()`` gives (unwrapped frame angle, frame speed, i_d, |i|, statusword) and keeps i_dq
    for the law; ``command(magnitude)`` sends the complex u the law left here (zero
    when the safe stop commands 0).
    """

    def __init__(self) -> None:
        self.drive: Any = None
        self.i_dq = 0j
        self.u = 0j
        self._angle: float | None = None
        self._turns = 0

    def feedback(self) -> Feedback:
        i_dq, angle, speed, statusword = self.drive.dq_feedback()
        self.i_dq = i_dq
        if self._angle is not None:  # unwrap the frame angle, so it is a position like any other
            self._turns += round((self._angle - angle) / (2.0 * math.pi))
        self._angle = angle
        return angle + 2.0 * math.pi * self._turns, speed, i_dq.real, abs(i_dq), statusword

    def command(self, magnitude: float) -> None:
        self.drive.dq_command(self.u if magnitude else 0j)

    def __getattr__(self, name: str) -> Any:  # fault, last_heartbeat, quick_stop, disable, sdo_read
        return getattr(self.drive, name)


def _dq_current(cfg: RigConfig, period: float) -> tuple[Law, Sequence[str], str]:
    """The complex-vector controller (32)-(34)/(37) over CAN (mode -2): reference i_q* step."""
    p = _params(
        cfg.controller,
        {"r1": 0.36, "l1": 6e-3, "gamma": 0.35, "f_line": 50.0, "middle": 0.0, "u_max": math.inf},
        cfg.source,
    )
    strategy = "s-pwm-middle" if p["middle"] else "s-pwm-start"
    ctl = ComplexVectorCurrentController(
        DqCurrentParams(p["r1"], p["l1"], period, p["gamma"], strategy, p["u_max"])
    )
    omega_k = 2.0 * math.pi * p["f_line"]
    ref = reference_of(cfg.reference)
    link = DqLink()

    def law(t: float, fb: Feedback) -> tuple[float, float, float, Sequence[float]]:
        i_q_ref, _ = ref(t)
        u = ctl.step(1j * i_q_ref, link.i_dq, omega_k)
        link.u = u
        return abs(u), i_q_ref, link.i_dq.imag, (link.i_dq.real, u.real, u.imag)

    law.dq_link = link  # type: ignore[attr-defined]
    return law, ("i_d", "u_d", "u_q"), "dq-voltage"


CONTROLLERS: dict[str, Callable[[RigConfig, float], tuple[Law, Sequence[str], str]]] = {
    "position-servo": _position_servo,
    "pi-speed": _pi_speed,
    "idtsm-speed": _idtsm_speed,
    "cascade-position": _cascade_position,
    "dq-current": _dq_current,
}


def build_law(cfg: RigConfig, period: float) -> tuple[Law, Sequence[str], str]:
    """(law, internal column names, drive mode) for ``[controller]``."""
    try:
        make = CONTROLLERS[cfg.controller.kind]
    except KeyError:
        raise ConfigError(
            f"{cfg.source}: [controller] kind = {cfg.controller.kind!r}; known: {', '.join(CONTROLLERS)}"
        ) from None
    try:
        return make(cfg, period)
    except ValueError as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(f"{cfg.source}: [controller] {cfg.controller.kind}: {exc}") from exc


def run_config(cfg: RigConfig, *, emulate: bool, duration: float | None = None) -> dict[str, Any]:
    """Run ``cfg``; returns the summary (``cycles``, ``rms_error``, ..., ``run_dir``)."""
    session = prepare(cfg, emulate=emulate, duration=duration)
    try:
        return session.loop.run()
    finally:
        session.close()


class Session:
    """A prepared run: the host loop, the host network and, when emulating, the hub and devices."""

    def __init__(
        self,
        loop: HostLoop,
        network: canopen.Network,
        hub: SyncHub | None,
        devices: list[EmulatedNode],
        buses: list[Any],
    ) -> None:
        self.loop, self.network, self.hub, self.devices, self._buses = loop, network, hub, devices, buses

    def close(self) -> None:
        for bus in self._buses:
            bus.shutdown()
        if self.hub is None:
            self.network.disconnect()


def prepare(cfg: RigConfig, *, emulate: bool, duration: float | None = None) -> Session:
    """Open the bus (or start the emulator), set the drive up and enable it; the loop is ready to run."""
    network = canopen.Network()
    buses: list[Any] = []
    devices: list[EmulatedNode] = []
    hub: SyncHub | None = None
    period = cfg.run.period
    if emulate:
        hub = SyncHub()
        device_network = canopen.Network()
        buses = [hub.bus(queue=False, channel="emulator"), hub.bus(queue=False, channel="host")]
        attach_network(device_network, buses[0])
        attach_network(network, buses[1])
        params = preset_values(cfg.emulator.preset, cfg.emulator.params)
        devices, preset_period = build_preset(cfg.emulator.preset, device_network, params)
        period = period or preset_period
        for d in devices:
            d.boot()
        plan = FaultPlan(**dataclasses.asdict(cfg.faults))
        if plan.active:
            buses.append(FaultInjector(plan, hub, devices[0]))
    else:
        if period <= 0.0:
            raise ConfigError(f"{cfg.source}: [run] period must be set (> 0 s) when not emulating")
        bus = open_bus(
            cfg.bus.interface,
            cfg.bus.channel,
            bitrate=cfg.bus.bitrate or None,
            **({"host": cfg.bus.host, "port": cfg.bus.port} if cfg.bus.interface == "socketcand" else {}),
        )
        network.bus = bus
        network.connect()
    realtime = cfg.run.time == "realtime"
    law, internals, mode = build_law(cfg, period)
    if cfg.drive.mode != mode:
        raise ConfigError(
            f"{cfg.source}: [drive] mode = {cfg.drive.mode!r}, but {cfg.controller.kind} commands {mode!r}"
        )
    cycles = round((duration or cfg.run.duration) / period)
    # flushed at least every 50 ms of run time: a killed host loses at most that
    recorder = Recorder(
        cfg.run.output,
        cfg.run.name,
        HostLoop.columns(internals),
        flush_every=max(1, round(0.05 / period)),
        trace=cfg.run.trace,
    )
    recorder.write_config(cfg.as_dict() | {"resolved_period": period, "emulate": emulate})
    if hub is not None:
        hub.taps.append(recorder.on_frame)
    try:
        drive = Cia402Drive(network, cfg.drive.node_id, eds=cfg.drive.eds or CIA402_EDS)
    except ConfigError:
        recorder.close({"cycles": 0, "safe_stop_reason": "setup failed", "run_dir": str(recorder.dir)})
        raise
    try:
        drive.connect()
        drive.nmt("PRE-OPERATIONAL")
        drive.set_mode(mode)
        if mode == "dq-voltage":
            drive.configure_dq_pdos(sync_rpdo=cfg.drive.sync_rpdo, latency_s=cfg.drive.latency)
        else:
            drive.configure_pdos(sync_rpdo=cfg.drive.sync_rpdo, latency_s=cfg.drive.latency)
        drive.nmt("OPERATIONAL")
        drive.enable(timeout=cfg.drive.enable_timeout)
    except (canopen.SdoCommunicationError, canopen.SdoAbortedError) as exc:
        recorder.close({"cycles": 0, "safe_stop_reason": "setup failed", "run_dir": str(recorder.dir)})
        if isinstance(exc, canopen.SdoAbortedError):
            raise SdoAbort("setup", code=exc.code, node_id=cfg.drive.node_id, index=0, subindex=0) from exc
        raise CommunicationTimeout(f"node {cfg.drive.node_id}: no SDO answer during setup ({exc})") from exc
    except Exception:
        recorder.close({"cycles": 0, "safe_stop_reason": "setup failed", "run_dir": str(recorder.dir)})
        raise

    if hub is not None:
        sync_hub = hub
        count = [0]

        def sync() -> None:  # emulated time from a count, so it does not drift by rounding
            count[0] += 1
            sync_hub.clock = count[0] * period
            network.send_message(0x80, b"")

        bus_time: Callable[[], float] = lambda: sync_hub.clock  # noqa: E731
    tpdo = drive.node.tpdo[2]
    paced = False
    if hub is None and realtime and cfg.bus.interface == "socketcan":
        # SYNC from the kernel's broadcast manager (python-can send_periodic): the kernel keeps the
        # period; each cycle waits for the drive's TPDO answering that SYNC.
        network.sync.start(period)
        paced = True
        timeout = cfg.limits.watchdog_periods * period

        def sync() -> None:
            tpdo.wait_for_reception(timeout=timeout)

    elif hub is None and realtime:

        def sync() -> None:
            network.sync.transmit()

    elif hub is None:  # lock-step over a real bus: each cycle waits for the drive's last TPDO
        answer = drive.node.tpdo[3]
        timeout = cfg.limits.watchdog_periods * period

        def sync() -> None:
            before = answer.timestamp
            network.sync.transmit()
            deadline = time.monotonic() + timeout
            while answer.timestamp == before and time.monotonic() < deadline:
                time.sleep(0.0001)

    if hub is None:
        bus_time = time.time
        assert network.notifier is not None
        network.notifier.add_listener(recorder.on_frame)  # the trace: every frame received
        if paced:
            buses.append(_KernelSync(network))
    link = getattr(law, "dq_link", None)
    if link is not None:
        link.drive = drive
    loop = HostLoop(
        link if link is not None else drive,
        law,
        Limits(cfg.limits, period),
        recorder,
        sync,
        period=period,
        cycles=cycles,
        internals=internals,
        realtime=realtime,
        tpdo_stamp=lambda: tpdo.timestamp,
        bus_time=bus_time,
        paced_by_bus=paced,
    )
    return Session(loop, network, hub, devices, buses)


class _KernelSync:
    """Stops the kernel's SYNC when the session closes (it sits with the buses to shut down)."""

    def __init__(self, network: Any) -> None:
        self.network = network

    def shutdown(self) -> None:
        self.network.sync.stop()
