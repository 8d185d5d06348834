"""The ``dyno`` preset: a drives-lab bench of a motor under test and a load machine on one shaft.

Three nodes: the motor under test behind its CiA 402 drive (node 1), a CiA 406
encoder on the shaft (node 2), and the load machine behind its CiA 402 drive
in CST (node 3). There is one mechanical model, that of the motor under test,
with the total inertia J = J_m + ``j_load`` and the motor's friction, viscous B and Coulomb
T_f (``plant_emulator.friction``):

    J domega/dt = T_m - B omega - T_f - T_L,    T_L = T_ext(t) - T_lm      ((3.4) / (4.2))

where T_m is the motor's torque, T_lm the load machine's (positive in the
direction of positive speed, so a braking load machine commands T_lm < 0) and
T_ext the emulator-internal ``load`` profile. The motor's own model integrates
it (the exact ZOH of (3.4) for the DC motor, RK4 of (4.1)-(4.2) for the IM), so
the DC motor under test stays as fast as the ``dc-servo`` preset's.

The load machine (``LoadMachineAxis``) is a servo motor (PMSM) whose drive
closes an ideal current loop: T_lm = k_t i_q with i_q = T*/k_t limited to the
maximum current (0x6073 per mille of 0x6075), optionally lagged by a first-order
``load_torque_lag`` [s]. Its drive supports CST only (0x6502).

``j_load`` defaults to 0: the papers give the total inertia of their benches
(Table II of the drives paper, "Total inertia", is IM1 with the load machine
IM2 coupled; the DC servo's a_m, b_m were identified on the whole mechanism),
so the motor's J already holds the load machine's rotor. Set it to add a
flywheel or a coupling.

The nodes share a ``Shaft`` (``plant_emulator.shaft``): it is advanced once
per SYNC with both drives' command timelines, whichever node handles the SYNC
first, and every node latches the shaft state at the SYNC instant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

import canopen

from drivers.maps import cia, cia406
from drivers.maps.cia import Mode
from drivers.schema import MAX_PERIOD, MIN_PERIOD, key
from plant_emulator.axes import Axis, LoadProfile
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.cia402_drive import EmulatedDrive, Ratings
from plant_emulator.cia406_encoder import EmulatedEncoder
from plant_emulator.parameters import load_torque, node_key, profile_text, require_nodes
from plant_emulator.shaft import Shaft

__all__ = ["DynoPreset", "LoadMachineAxis", "build_dyno"]

T = TypeVar("T")
_CST = Mode.CST  # looked up once, compared on every command


def _rating(unit: str, doc: str, **allowed: Any) -> Any:
    """A rating of the motor or the load machine; None: the motor under test's."""
    return key(None, unit, doc, **allowed)


@dataclass(frozen=True)
class DynoPreset:
    """Parameters of ``dyno`` (SI; see the module docstring); None: the motor under test's value."""

    motor: Literal["dc", "im"] = key(
        "dc", "", "dc: the DC motor (3.4) of dc-servo; im: IM1 under FOC of im-drive"
    )
    period: float = key(
        0.4e-3,
        "s",
        "the SYNC period",
        ge=MIN_PERIOD,
        le=MAX_PERIOD,
        rule=f"a period of {MIN_PERIOD:g} .. {MAX_PERIOD:g} s",
    )
    counts_per_rev: int = key(
        4096, "increments/rev", "position resolution of both drives and the encoder", ge=1, le=0x7FFF_FFFF
    )
    j_load: float = key(0.0, "kg m^2", "inertia added to the motor's total J", ge=0.0)
    load: str = key(
        "none",
        "N m",
        "emulator-internal load torque T_ext of time (plant_emulator.profiles)",
        check=profile_text,
    )
    rated_current: float | None = _rating("A", "motor, 0x6075 (dc 10 A, im 4.6 A)", gt=0.0)
    rated_torque: float | None = _rating("N m", "motor, 0x6076 (dc k_t 10 A = 0.235 N m, im 5 N m)", gt=0.0)
    max_current_permille: int | None = _rating(
        "per mille", "motor, 0x6073 (dc 3000, im 2500)", ge=1, le=0xFFFF
    )
    max_speed_rpm: int | None = _rating("rpm", "motor, 0x6080 (dc 6000, im 3600)", ge=1, le=0xFFFF_FFFF)
    friction: float | None = _rating("N m s/rad", "motor, viscous B (dc 2.29e-6, im 0.0022)", ge=0.0)
    coulomb: float | None = _rating("N m", "motor, Coulomb friction T_c (dc 1.1e-3, im 2e-3)", ge=0.0)
    load_rated_torque: float | None = _rating("N m", "load machine, 0x6076 (the motor's)", gt=0.0)
    load_rated_current: float | None = _rating("A", "load machine, 0x6075 (the motor's)", gt=0.0)
    load_max_permille: int = key(
        3000, "per mille", "load machine, 0x6073, of its rated current", ge=1, le=0xFFFF
    )
    load_max_speed_rpm: int | None = _rating(
        "rpm", "load machine, 0x6080 (the motor's)", ge=1, le=0xFFFF_FFFF
    )
    load_torque_lag: float = key(0.0, "s", "load machine's torque lag (0: ideal)", ge=0.0)
    drive_node: int = node_key(1, "the motor under test's drive")
    encoder_node: int = node_key(2, "the encoder")
    load_node: int = node_key(3, "the load machine's drive")

    def __post_init__(self) -> None:
        require_nodes(self, "drive_node", "encoder_node", "load_node")

    def motor_ratings(self, motor: Ratings) -> Ratings:
        """The motor under test's ratings: those given here, else the motor's own ``motor``."""
        return Ratings(
            rated_current=_given(self.rated_current, motor.rated_current),
            rated_torque=_given(self.rated_torque, motor.rated_torque),
            max_current_permille=_given(self.max_current_permille, motor.max_current_permille),
            max_speed_rpm=_given(self.max_speed_rpm, motor.max_speed_rpm),
        )

    def load_ratings(self, motor: Ratings) -> Ratings:
        """The load machine's ratings, the motor under test's ``motor`` where not given."""
        return Ratings(
            rated_current=_given(self.load_rated_current, motor.rated_current),
            rated_torque=_given(self.load_rated_torque, motor.rated_torque),
            max_current_permille=self.load_max_permille,
            max_speed_rpm=_given(self.load_max_speed_rpm, motor.max_speed_rpm),
        )


def _given(value: T | None, default: T) -> T:
    return default if value is None else value


class LoadMachineAxis(Axis):
    """A torque source on the shaft of ``motion``: T = k_t i_q (see the module docstring).

    ``k_t`` [N m/A], ``i_max`` [A] the current limit, ``tau`` [s] the current loop's
    first-order lag (0: i_q follows its reference at once). Over each piece of a period
    the shaft sees ``held``, the mean torque of that piece (exact for the lag).
    """

    modes = (Mode.CST,)

    def __init__(self, motion: Axis, *, k_t: float, i_max: float, tau: float = 0.0) -> None:
        for name, value in (("k_t", k_t), ("i_max", i_max)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"load machine {name} must be > 0, got {value!r}")
        if not (math.isfinite(tau) and tau >= 0.0):
            raise ValueError(f"load machine tau must be >= 0 s, got {tau!r}")
        self.motion = motion
        self.k_t, self.i_max, self.tau = k_t, i_max, tau
        self.i_ref = 0.0  #: current reference [A]
        self.i_q = 0.0  #: current [A] at the present instant
        self.held = 0.0  #: torque on the shaft over the present piece of the period [N m]

    def set_command(self, mode: int, value: complex | float, *, computed_one_sync_ago: bool = False) -> None:
        """Torque command [N m] (CST), limited to k_t i_max."""
        if mode != _CST:
            raise ValueError(f"the load machine has only mode {Mode.CST}, got {mode}")
        torque = value.real if isinstance(value, complex) else value
        self.i_ref = max(-self.i_max, min(self.i_max, torque / self.k_t))
        if self.tau == 0.0:
            self.i_q = self.i_ref

    def coast(self) -> None:
        """Inverter off: the current, and the torque, vanish at once."""
        self.i_ref = self.i_q = self.held = 0.0

    def reset(self) -> None:
        self.coast()

    def advance(self, h: float, t: float) -> None:
        """Over h [s]: ``held`` = mean of k_t i_q, i_ref + (i_q - i_ref) exp(-s/tau) for 0 <= s < h."""
        if h <= 0.0:
            return
        if self.tau == 0.0:
            self.held = self.k_t * self.i_q
            return
        decay = math.exp(-h / self.tau)
        error = self.i_q - self.i_ref
        self.held = self.k_t * (self.i_ref + error * self.tau / h * (1.0 - decay))
        self.i_q = self.i_ref + error * decay

    @property
    def position(self) -> float:
        return self.motion.position

    @property
    def velocity(self) -> float:
        return self.motion.velocity

    @property
    def current(self) -> float:
        return self.i_q

    @property
    def torque(self) -> float:
        return self.k_t * self.i_q


def _shaft_load(external: LoadProfile | None, machine: LoadMachineAxis) -> LoadProfile:
    """T_L(t) = T_ext(t) - T_lm on the motor under test [N m]."""
    if external is None:
        return lambda t: -machine.held
    return lambda t: external(t) - machine.held


def build_dyno(p: DynoPreset, network: canopen.Network, motor: Axis, ratings: Ratings) -> list[EmulatedNode]:
    """The dyno's nodes on ``network``: [motor drive, encoder, load machine drive].

    ``motor`` is the motor under test's axis, built with the total inertia and with
    ``load`` free (this sets it to the shaft's T_L); ``ratings`` are its drive's.
    """
    load_ratings = p.load_ratings(ratings).as_stored()  # its torque = k_t i_q agrees with 0x6076, 0x6075
    machine = LoadMachineAxis(
        motor,
        k_t=load_ratings.rated_torque / load_ratings.rated_current,
        i_max=load_ratings.max_current_permille / 1000.0 * load_ratings.rated_current,
        tau=p.load_torque_lag,
    )
    motor.load = _shaft_load(load_torque(p.load), machine)
    shaft = Shaft(motor, sources=(machine,), period=p.period)
    drive = EmulatedDrive(p.drive_node, network, motor, period=p.period, shaft=shaft)
    drive.rate(ratings, counts_per_rev=p.counts_per_rev)
    encoder = EmulatedEncoder(p.encoder_node, network, shaft, period=p.period)
    encoder.write(cia406.ENCODER_RESOLUTION, 0, p.counts_per_rev)
    load = EmulatedDrive(p.load_node, network, machine, period=p.period, shaft=shaft)
    load.rate(load_ratings, counts_per_rev=p.counts_per_rev)
    # CST selected where the drive has no voltage mode (the load machine, the IM's FOC drive)
    for d in (drive, load):
        if Mode.VOLTAGE not in d.axis.modes:
            d.write(cia.MODES_OF_OPERATION, 0, Mode.CST)
            d.write(cia.MODES_DISPLAY, 0, Mode.CST)
    return [drive, encoder, load]
