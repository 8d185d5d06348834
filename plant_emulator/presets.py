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
from dataclasses import replace
from typing import Any

import canopen

from drivers.maps import cia, cia406
from drivers.maps.cia import Mode, map_entry
from drivers.profiles import profile_peak
from plant_emulator.axes import Axis, DcServoAxis, ServoLoops
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.cia402_drive import EmulatedDrive, Ratings
from plant_emulator.cia406_encoder import EmulatedEncoder
from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.device_profile import DeviceProfile
from plant_emulator.dyno import build_dyno, motor_ratings
from plant_emulator.grid_axis import GridAxis
from plant_emulator.induction_motor import ImAxis, ImParams
from plant_emulator.parameters import load_torque
from plant_emulator.preset_params import (
    DC_COULOMB,
    DC_VISCOUS,
    PRESETS,
    DcServoPreset,
    DynoPreset,
    GridConverterPreset,
    ImDrivePreset,
    preset_params,
    preset_period,
)
from plant_emulator.rl_dq import RLParams

__all__ = [
    "DC_COULOMB",
    "DC_VISCOUS",
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


def build_preset(
    name: str,
    network: canopen.Network,
    params: Mapping[str, object] | Any = None,
) -> tuple[list[EmulatedNode], float]:
    """Create the devices of preset ``name`` on ``network``: (devices, SYNC period [s]).

    ``params`` sets parameters by name (``a_m`` or ``plant.a_m``) to typed values, or is the
    preset's dataclass built already, see ``preset_params``.

    Parameters
    ----------
    name : str
        A preset (``PRESETS``).
    network : canopen.Network
        The canopen network the devices answer on.
    params : Mapping[str, object] | Any, optional
        Typed values by name (``a_m`` or ``plant.a_m``), or the preset's dataclass built already.

    Returns
    -------
    tuple[list[EmulatedNode], float]
        (the devices, the SYNC period [s]).
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

    The motor (a motor per axis on a drive of several: ``plant_emulator.multi_axis``) is the
    profile's physics preset with the profile's ``[physics.params]`` and then
    ``params`` applied (or ``params``, the preset's dataclass built over the profile's already);
    the drive keeps its own EDS's resolution (0x608F), and takes the motor's ratings into the
    objects it has.

    Parameters
    ----------
    profile : DeviceProfile
        The drive's device profile.
    network : canopen.Network
        The canopen network it answers on.
    params : Mapping[str, object] | Any, optional
        The physics preset's values by name, or its dataclass built already.
    node_id : int | None, optional
        Its node-ID (None: the profile's).

    Returns
    -------
    tuple[list[EmulatedNode], float]
        ([the drive], the SYNC period [s]).

    Raises
    ------
    ValueError
        If the profile's physics is none a twin runs.
    """
    if profile.physics not in TWIN_PHYSICS:
        raise ValueError(
            f"{profile.source}: physics {profile.physics!r}: a twin runs {' or '.join(TWIN_PHYSICS)}"
        )
    schema = PRESETS.get(profile.physics)
    built = schema is not None and isinstance(params, schema)
    p: Any = params if built else preset_params(profile.physics, {**profile.params, **(params or {})})
    motors = [_motor(p) for _ in range(profile.axes)]  # a drive of several axes: a motor each
    node = node_id or profile.node_id
    drive: EmulatedDrive
    if profile.axes > 1:
        from plant_emulator.multi_axis import MultiAxisDrive

        axes = [axis for axis, _ in motors]
        drive = MultiAxisDrive(node, network, axes, period=p.period, profile=profile)
    else:
        drive = EmulatedDrive(node, network, motors[0][0], period=p.period, profile=profile)
    drive.rate(motors[0][1], counts_per_rev=None)
    return [drive], p.period


def _motor(p: DcServoPreset | ImDrivePreset) -> tuple[Axis, Ratings]:
    """The motor of a twin's preset ``p`` behind its drive, and its ratings."""
    return _dc_axis(p, period=p.period) if isinstance(p, DcServoPreset) else _im_axis(p)


def _dc_axis(p: DcServoPreset, *, period: float, j_load: float = 0.0) -> tuple[DcServoAxis, Ratings]:
    """The DC motor (3.4) of ``p`` with ``j_load`` [kg m^2] added to J, behind its drive's loops
    (speed PI at the bandwidth ``speed_bandwidth_hz`` for the total J, position P at a fifth of it)."""
    motor = DCMotorParams.from_am_bm(a_m=p.a_m, b_m=p.b_m, r_r=p.r_r, tau_e=p.tau_e, b=p.friction)
    motor = replace(motor, j=motor.j + j_load)
    w_c = 2.0 * math.pi * p.speed_bandwidth_hz
    max_torque = motor.k_t * p.rated_current * p.max_current_permille / 1000.0
    loops = ServoLoops(motor.j * w_c, motor.j * w_c * w_c / 5.0, w_c / 5.0, max_torque, p.u_max)
    axis = DcServoAxis(motor, loops, inner_dt=period / 4, load=load_torque(p.load), coulomb=p.coulomb)
    ratings = Ratings(
        p.rated_current,
        motor.k_t * p.rated_current,
        p.max_current_permille,
        p.max_speed_rpm,
        _dc_peak_acceleration(motor, p, max_torque),
    )
    return axis, ratings


def _dc_peak_acceleration(motor: DCMotorParams, p: DcServoPreset, max_torque: float) -> float:
    """[rad/s^2] the most the DC motor (3.4) of ``p`` can speed up or slow down, up to twice its
    0x6080 speed (the drive trips above it): the larger of its loops' torque limit and the current
    the power stage drives through it ((u_max + k_e w)/R_r, voltage mode), with the friction's and
    the load's most, over J."""
    w = 2.0 * p.max_speed_rpm * 2.0 * math.pi / 60.0
    drive = max(max_torque, motor.k_t * (p.u_max + motor.k_e * w) / motor.r_r)
    return (drive + p.coulomb + motor.b * w + profile_peak(p.load)) / motor.j


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
    drive, encoder, load = build_dyno(p, network, axis, motor_ratings(p, ratings))
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
