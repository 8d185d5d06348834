"""Physics presets behind the emulated devices, and a lock-step bench to run them.

- ``dc-servo``: the drives paper's DC servo (a_m = 16 1/s, b_m = 680 rad/(V s^2),
  section VII.B) as the full model (3.4) with R_r = 1 Ohm, L_r = 0.1 mH,
  k_e = k_t = a_m/b_m, J = k_t/(R_r b_m); a 4096-count encoder; T = 0.4 ms;
  48 V power stage. Drive node 1 (CiA 402, voltage mode -1 and CST/CSV/PV/CSP)
  and encoder node 2 (CiA 406) on the same shaft. Friction, so that a motor left alone
  comes to rest: Coulomb ``coulomb`` with stiction (``plant_emulator.friction``) and viscous
  ``friction`` B, which is part of a_m, not added to it (``DCMotorParams.from_am_bm``: the
  a_m = 16 of section VII.B was identified on the motor, friction and all). The paper names no
  motor; the defaults are those of the catalogue motor nearest the preset's constants
  (k = a_m/b_m = 23.5 mN m/A at R_r = 1 Ohm): FAULHABER 3564 K 024 B (k_M 20.1 mN m/A,
  R 1.2 Ohm), friction torque static C_o = 1.10 mN m and dynamic C_v = 2.4e-4 mN m/rpm
  (FAULHABER's data sheet of the 3564 K 024 B), i.e. T_c = 1.1e-3 N m, B = 2.29e-6 N m s/rad.
- ``grid-converter``: Table IV of the dq-current paper (L1 = 6 mH, R1 = 0.36 Ohm,
  50 Hz, 400 V grid, U_DC = 700 V) at omega_k/omega_s = 1/27; node 1 in mode -2
  takes u_d, u_q [mV] in RPDO1 and sends i_d, i_q [mA] in TPDO4 and the angle in
  TPDO2. ``strategy`` s-pwm-start makes RPDO1 synchronous (applied at the next
  SYNC, T_d = T_s); s-pwm-middle makes it event-driven with 0x2001 = T_s/2.

- ``dyno``: a bench of a motor under test (``motor``: the DC motor of dc-servo or
  the IM of im-drive) at node 1, an encoder at node 2 and a load machine in CST at
  node 3, all on one shaft (``plant_emulator.dyno``).
- ``im-drive``: the induction motor IM1 of Table II under indirect rotor FOC with
  the PI current loops of Table III inside the drive at 0.1 ms
  (``plant_emulator.induction_motor``); T = 0.5 ms (the speed loop's period of
  section VII.C); the host closes speed or position through CST (torque in per
  mille of 0x6076 = 5 N m, the rated 1.5 kW at 2860 rpm); encoder node 2. Viscous
  ``friction`` B of Table II and Coulomb ``coulomb`` (``ImParams.coulomb``: its source).

Each drive says in 0x1008 what it is (``PRODUCT_NAMES``; the EDS's name is the DC servo
drive's), and an induction-motor inverter's 0x1000 has the CiA 402 type 0x01, a frequency
converter, in its additional information (the servo drives' 0x02).

Every parameter is a key of its preset's dataclass (``drivers.schema.key``: unit, range,
meaning) and can be set by name to a typed value (``params``, checked by
``plant_emulator.parameters``); an unknown name, a value of the wrong type or out of range
is a ValueError naming it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, Literal

import canopen

from drivers.maps import cia, cia406
from drivers.maps.cia import Mode, map_entry
from drivers.schema import MAX_PERIOD, MIN_PERIOD, Refused, key
from plant_emulator.axes import Axis, DcServoAxis, GridAxis, ServoLoops
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.cia402_drive import EmulatedDrive, Ratings
from plant_emulator.cia406_encoder import EmulatedEncoder
from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.device_profile import DeviceProfile
from plant_emulator.dyno import DynoPreset, build_dyno
from plant_emulator.induction_motor import ImAxis, ImParams
from plant_emulator.parameters import load_torque, node_key, profile_text, require_nodes, with_params
from plant_emulator.rl_dq import RLParams

__all__ = [
    "PRESETS",
    "DcServoPreset",
    "DynoPreset",
    "GridConverterPreset",
    "ImDrivePreset",
    "build_preset",
    "build_twin",
    "preset_params",
    "preset_period",
]


#: the dc-servo motor's friction (module docstring): FAULHABER 3564 K 024 B, C_o and C_v
DC_COULOMB = 1.10e-3  #: [N m]
DC_VISCOUS = 2.4e-7 * 60.0 / (2.0 * math.pi)  #: [N m s/rad] (2.4e-4 mN m/rpm)


#: keys every preset with a drive and an encoder has
_PERMILLE = "per mille of the rated current"


def _period(default: float) -> Any:
    rule = f"a period of {MIN_PERIOD:g} .. {MAX_PERIOD:g} s"
    return key(default, "s", "the SYNC period", ge=MIN_PERIOD, le=MAX_PERIOD, rule=rule)


def _counts() -> Any:
    return key(4096, "increments/rev", "position resolution (0x608F, 0x6001)", ge=1, le=0x7FFF_FFFF)


def _load() -> Any:
    return key(
        "none", "N m", "load torque of time, plant_emulator.profiles (e.g. sine:5:1)", check=profile_text
    )


@dataclass(frozen=True)
class DcServoPreset:
    """Parameters of ``dc-servo`` (SI; see the module docstring)."""

    a_m: float = key(16.0, "1/s", "(3.5)", gt=0.0)
    b_m: float = key(680.0, "rad/(V s^2)", "(3.5)", gt=0.0)
    r_r: float = key(1.0, "Ohm", "armature resistance", gt=0.0)
    tau_e: float = key(1e-4, "s", "electrical time constant L_r/R_r", gt=0.0)
    friction: float = key(DC_VISCOUS, "N m s/rad", "viscous B, part of a_m (module docstring)", ge=0.0)
    coulomb: float = key(DC_COULOMB, "N m", "Coulomb friction T_c, breakaway and kinetic", ge=0.0)
    counts_per_rev: int = _counts()
    period: float = _period(0.4e-3)
    u_max: float = key(48.0, "V", "power stage voltage limit", gt=0.0)
    rated_current: float = key(10.0, "A", "0x6075", gt=0.0)
    max_current_permille: int = key(3000, _PERMILLE, "0x6073", ge=1, le=0xFFFF)
    max_speed_rpm: int = key(6000, "rpm", "0x6080", ge=1, le=0xFFFF_FFFF)
    speed_bandwidth_hz: float = key(100.0, "Hz", "of the drive's speed loop", gt=0.0)
    load: str = _load()
    drive_node: int = node_key(1, "the drive's node id")
    encoder_node: int = node_key(2, "the encoder's node id")

    def __post_init__(self) -> None:
        require_nodes(self, "drive_node", "encoder_node")
        try:
            DCMotorParams.from_am_bm(a_m=self.a_m, b_m=self.b_m, r_r=self.r_r, b=self.friction)
        except ValueError as exc:
            raise Refused("friction", self.friction, str(exc)) from None


@dataclass(frozen=True)
class GridConverterPreset:
    """Parameters of ``grid-converter`` (SI; see the module docstring)."""

    L1: float = key(6e-3, "H", "the line inductance", gt=0.0)
    R1: float = key(0.36, "Ohm", "its resistance", gt=0.0)
    f_line: float = key(50.0, "Hz", "grid frequency", gt=0.0)
    ratio: float = key(1.0 / 27.0, "", "omega_k/omega_s: the SYNC period is ratio/f_line", gt=0.0)
    u_line_rms: float = key(400.0, "V", "line-to-line grid voltage (rms)", ge=0.0)
    u_dc: float = key(700.0, "V", "DC link", gt=0.0)
    rated_current: float = key(32.0 * math.sqrt(2.0), "A", "0x6075", gt=0.0)
    max_current_permille: int = key(2000, _PERMILLE, "0x6073", ge=1, le=0xFFFF)
    strategy: Literal["s-pwm-start", "s-pwm-middle"] = key(
        "s-pwm-start",
        "",
        "s-pwm-start: RPDO1 applied at the next SYNC; s-pwm-middle: on receipt, 0x2001 = T_s/2",
    )
    drive_node: int = node_key(1, "the converter's node id")

    def __post_init__(self) -> None:
        period = self.period
        if not MIN_PERIOD <= period <= MAX_PERIOD:
            raise Refused("ratio/f_line", period, f"must be a period of {MIN_PERIOD:g} .. {MAX_PERIOD:g} s")

    @property
    def period(self) -> float:
        """SYNC period [s]."""
        return self.ratio / self.f_line


@dataclass(frozen=True)
class ImDrivePreset:
    """Parameters of ``im-drive`` (SI; see the module docstring; the motor is ``ImParams``)."""

    period: float = _period(0.5e-3)
    counts_per_rev: int = _counts()
    rated_torque: float = key(5.0, "N m", "0x6076", gt=0.0)
    rated_current: float = key(3.25 * math.sqrt(2.0), "A", "0x6075", gt=0.0)
    max_current_permille: int = key(2500, _PERMILLE, "0x6073", ge=1, le=0xFFFF)
    max_speed_rpm: int = key(3600, "rpm", "0x6080", ge=1, le=0xFFFF_FFFF)
    i_ds_ref: float = key(2.35, "A", "flux current (4.7)", gt=0.0)
    friction: float = key(ImParams.b, "N m s/rad", "viscous B (Table II)", ge=0.0)
    coulomb: float = key(ImParams.coulomb, "N m", "Coulomb friction T_c, breakaway and kinetic", ge=0.0)
    load: str = _load()
    drive_node: int = node_key(1, "the drive's node id")
    encoder_node: int = node_key(2, "the encoder's node id")

    def __post_init__(self) -> None:
        require_nodes(self, "drive_node", "encoder_node")


PRESETS: dict[str, type] = {
    "dc-servo": DcServoPreset,
    "im-drive": ImDrivePreset,
    "grid-converter": GridConverterPreset,
    "dyno": DynoPreset,
}


def preset_params(name: str, params: Mapping[str, object] | Any = None) -> Any:
    """The parameters of preset ``name`` with ``params`` (typed values by name) applied, or
    ``params`` itself where it is the preset's dataclass, built (and checked) already.

    ValueError naming an unknown preset, an unknown parameter (with the known ones), a value
    of the wrong type (with the expected one) or out of range.
    """
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; known: {', '.join(PRESETS)}")
    return with_params(PRESETS[name], params)


def preset_period(name: str, params: Mapping[str, object] | Any = None) -> float:
    """The SYNC period [s] preset ``name`` runs at, with ``params`` applied."""
    return float(preset_params(name, params).period)


def build_preset(
    name: str,
    network: canopen.Network,
    params: Mapping[str, object] | Any = None,
) -> tuple[list[EmulatedNode], float]:
    """Create the devices of preset ``name`` on ``network``: (devices, SYNC period [s]).

    ``params`` sets parameters by name (``a_m`` or ``plant.a_m``) to typed values, or is the
    preset's dataclass built already, see ``preset_params``.
    """
    p = preset_params(name, params)
    if isinstance(p, DcServoPreset):
        return _dc_servo(p, network), p.period
    if isinstance(p, ImDrivePreset):
        return _im_drive(p, network), p.period
    if isinstance(p, DynoPreset):
        return _dyno(p, network), p.period
    return _grid(p, network), p.period


#: the presets a twin's profile may put behind its drive (one motor, one drive)
TWIN_PHYSICS = ("dc-servo", "im-drive")


def build_twin(
    profile: DeviceProfile,
    network: canopen.Network,
    params: Mapping[str, object] | Any = None,
    *,
    node_id: int | None = None,
) -> tuple[list[EmulatedNode], float]:
    """The virtual twin of ``profile``'s drive on ``network``: (its one drive, SYNC period [s]).

    The motor is the profile's physics preset with the profile's ``[physics.params]`` and then
    ``params`` applied (or ``params``, the preset's dataclass built over the profile's already);
    the drive keeps its own EDS's resolution (0x608F), and takes the motor's ratings into the
    objects it has.
    """
    if profile.physics not in TWIN_PHYSICS:
        raise ValueError(
            f"{profile.source}: physics {profile.physics!r}: a twin runs {' or '.join(TWIN_PHYSICS)}"
        )
    schema = PRESETS.get(profile.physics)
    built = schema is not None and isinstance(params, schema)
    p: Any = params if built else preset_params(profile.physics, {**profile.params, **(params or {})})
    axis: Axis
    if isinstance(p, DcServoPreset):
        axis, ratings = _dc_axis(p, period=p.period)
    else:
        axis, ratings = _im_axis(p)
    drive = EmulatedDrive(node_id or profile.node_id, network, axis, period=p.period, profile=profile)
    drive.rate(ratings, counts_per_rev=None)
    return [drive], p.period


def _dc_axis(p: DcServoPreset, *, period: float, j_load: float = 0.0) -> tuple[DcServoAxis, Ratings]:
    """The DC motor (3.4) of ``p`` with ``j_load`` [kg m^2] added to J, behind its drive's loops
    (speed PI at the bandwidth ``speed_bandwidth_hz`` for the total J, position P at a fifth of it)."""
    motor = DCMotorParams.from_am_bm(a_m=p.a_m, b_m=p.b_m, r_r=p.r_r, tau_e=p.tau_e, b=p.friction)
    motor = replace(motor, j=motor.j + j_load)
    w_c = 2.0 * math.pi * p.speed_bandwidth_hz
    max_torque = motor.k_t * p.rated_current * p.max_current_permille / 1000.0
    loops = ServoLoops(motor.j * w_c, motor.j * w_c * w_c / 5.0, w_c / 5.0, max_torque, p.u_max)
    axis = DcServoAxis(motor, loops, inner_dt=period / 4, load=load_torque(p.load), coulomb=p.coulomb)
    ratings = Ratings(p.rated_current, motor.k_t * p.rated_current, p.max_current_permille, p.max_speed_rpm)
    return axis, ratings


def _im_axis(p: ImDrivePreset, *, j_load: float = 0.0) -> tuple[ImAxis, Ratings]:
    """IM1 of Table II under FOC with ``j_load`` [kg m^2] added to its total inertia."""
    motor = ImParams(i_ds_ref=p.i_ds_ref, b=p.friction, coulomb=p.coulomb)
    axis = ImAxis(replace(motor, j=motor.j + j_load), load=load_torque(p.load))
    return axis, Ratings(p.rated_current, p.rated_torque, p.max_current_permille, p.max_speed_rpm)


def _with_encoder(
    drive: EmulatedDrive, p: DcServoPreset | ImDrivePreset, network: canopen.Network
) -> list[EmulatedNode]:
    encoder = EmulatedEncoder(p.encoder_node, network, drive.shaft, period=p.period)
    encoder.write(cia406.ENCODER_RESOLUTION, 0, p.counts_per_rev)
    return [drive, encoder]


#: 0x1008 of the presets' drives that are not the EDS's DC servo drive
PRODUCT_NAMES = {
    "im": "drive-rig emulated induction-motor inverter (FOC)",
    "grid": "drive-rig emulated grid converter (dq current control)",
    "load": "drive-rig emulated load machine (dyno)",
}
FREQUENCY_CONVERTER = 0x0001_0000 | cia.PROFILE_DRIVE  #: 0x1000 of a CiA 402 frequency converter


def _name(drive: EmulatedNode, kind: str) -> None:
    """0x1008 (and, for an inverter, 0x1000) of ``drive`` say it is a ``kind`` of PRODUCT_NAMES."""
    drive.write(cia.DEVICE_NAME, 0, PRODUCT_NAMES[kind])
    if kind == "im":
        drive.write(cia.DEVICE_TYPE, 0, FREQUENCY_CONVERTER)


def _im_drive(p: ImDrivePreset, network: canopen.Network) -> list[EmulatedNode]:
    axis, ratings = _im_axis(p)
    drive = EmulatedDrive(p.drive_node, network, axis, period=p.period)
    _name(drive, "im")
    drive.rate(ratings, counts_per_rev=p.counts_per_rev)
    drive.write(cia.MODES_OF_OPERATION, 0, Mode.CST)
    drive.write(cia.MODES_DISPLAY, 0, Mode.CST)
    return _with_encoder(drive, p, network)


def _dc_servo(p: DcServoPreset, network: canopen.Network) -> list[EmulatedNode]:
    axis, ratings = _dc_axis(p, period=p.period)
    drive = EmulatedDrive(p.drive_node, network, axis, period=p.period)
    drive.rate(ratings, counts_per_rev=p.counts_per_rev)
    return _with_encoder(drive, p, network)


#: the dyno's motor parameters that are also parameters of the dc-servo and im-drive presets
_MOTOR_RATINGS = ("rated_current", "max_current_permille", "max_speed_rpm", "friction", "coulomb")


def _dyno(p: DynoPreset, network: canopen.Network) -> list[EmulatedNode]:
    """The motor under test from the dc-servo or im-drive preset (its own load none: the dyno's
    ``load`` acts on the shaft), with the dyno's ratings where given."""
    given = {k: getattr(p, k) for k in _MOTOR_RATINGS if getattr(p, k) is not None}
    axis: Axis
    if p.motor == "dc":
        axis, ratings = _dc_axis(replace(DcServoPreset(), **given), period=p.period, j_load=p.j_load)
    else:
        axis, ratings = _im_axis(replace(ImDrivePreset(), **given), j_load=p.j_load)
    drive, encoder, load = build_dyno(p, network, axis, p.motor_ratings(ratings))
    if p.motor != "dc":
        _name(drive, "im")
    _name(load, "load")
    return [drive, encoder, load]


def _grid(p: GridConverterPreset, network: canopen.Network) -> list[EmulatedNode]:
    omega = 2.0 * math.pi * p.f_line
    source = complex(p.u_line_rms * math.sqrt(2.0 / 3.0), 0.0)  # phase peak, d-aligned
    axis = GridAxis(
        RLParams(p.R1, p.L1, p.period), omega_k=omega, source=source, u_max=p.u_dc / math.sqrt(3.0)
    )
    drive = EmulatedDrive(p.drive_node, network, axis, period=p.period)
    _name(drive, "grid")
    drive.write(cia.RATED_CURRENT, 0, round(p.rated_current * 1000))  # mA
    drive.write(cia.MAX_CURRENT, 0, p.max_current_permille)
    drive.write(cia.MODES_OF_OPERATION, 0, Mode.DQ_VOLTAGE)
    drive.write(cia.MODES_DISPLAY, 0, Mode.DQ_VOLTAGE)
    event = p.strategy == "s-pwm-middle"
    # RPDO1: u_d, u_q [mV]; TPDO2: frame angle and speed; TPDO4 (i_d, i_q) valid
    drive.write(cia.RPDO_COMM, cia.PDO_COMM_TYPE, cia.PDO_EVENT if event else 1)
    drive.write(cia.COMMAND_LATENCY, 0, round(p.period / 2 * 1e6) if event else 0)  # us
    drive.write(cia.RPDO_MAP, 0, 2)
    drive.write(cia.RPDO_MAP, 1, map_entry(cia.DQ_VOLTAGE, 1, 32))
    drive.write(cia.RPDO_MAP, 2, map_entry(cia.DQ_VOLTAGE, 2, 32))
    drive.write(cia.TPDO_MAP + 1, 1, map_entry(cia.FRAME_ANGLE, 0, 32))
    drive.write(cia.TPDO_MAP + 1, 2, map_entry(cia.FRAME_SPEED, 0, 32))
    drive.write(cia.TPDO_COMM + 3, cia.PDO_COMM_COB_ID, cia.COB_TPDO[3] + p.drive_node)
    return [drive]
