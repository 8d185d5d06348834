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
from typing import TypeVar

import canopen

from drivers.maps import cia, cia406
from drivers.maps.cia import Mode
from plant_emulator.axes import Axis, LoadProfile
from plant_emulator.canopen_node import EmulatedNode
from plant_emulator.cia402_drive import EmulatedDrive, Ratings
from plant_emulator.cia406_encoder import EmulatedEncoder
from plant_emulator.parameters import load_torque
from plant_emulator.preset_params import DynoPreset
from plant_emulator.shaft import Shaft

__all__ = ["DynoPreset", "LoadMachineAxis", "build_dyno", "load_ratings", "motor_ratings"]

T = TypeVar("T")
_CST = Mode.CST  # looked up once, compared on every command


def motor_ratings(p: DynoPreset, motor: Ratings) -> Ratings:
    """The motor under test's ratings: those ``p`` gives, else the motor's own ``motor``.

    Parameters
    ----------
    p : DynoPreset
        The dyno preset.
    motor : Ratings
        The motor's own ratings.

    Returns
    -------
    Ratings
        The motor under test's ratings.
    """
    return Ratings(
        rated_current=_given(p.rated_current, motor.rated_current),
        rated_torque=_given(p.rated_torque, motor.rated_torque),
        max_current_permille=_given(p.max_current_permille, motor.max_current_permille),
        max_speed_rpm=_given(p.max_speed_rpm, motor.max_speed_rpm),
    )


def load_ratings(p: DynoPreset, motor: Ratings) -> Ratings:
    """The load machine's ratings in ``p``, the motor under test's ``motor`` where not given.

    Parameters
    ----------
    p : DynoPreset
        The dyno preset.
    motor : Ratings
        The motor under test's ratings.

    Returns
    -------
    Ratings
        The load machine's ratings.
    """
    return Ratings(
        rated_current=_given(p.load_rated_current, motor.rated_current),
        rated_torque=_given(p.load_rated_torque, motor.rated_torque),
        max_current_permille=p.load_max_permille,
        max_speed_rpm=_given(p.load_max_speed_rpm, motor.max_speed_rpm),
    )


def _given(value: T | None, default: T) -> T:
    return default if value is None else value


class LoadMachineAxis(Axis):
    """A torque source on the shaft of ``motion``: T = k_t i_q (see the module docstring).

    ``k_t`` [N m/A], ``i_max`` [A] the current limit, ``tau`` [s] the current loop's
    first-order lag (0: i_q follows its reference at once). Over each piece of a period
    the shaft sees ``held``, the mean torque of that piece (exact for the lag).

    Parameters
    ----------
    motion : Axis
        The axis whose shaft it loads.
    k_t : float
        [N m/A] the torque constant.
    i_max : float
        [A] the current limit.
    tau : float, optional
        [s] the current loop's time constant (0: immediate).

    Raises
    ------
    ValueError
        If ``k_t`` or ``i_max`` is not > 0, or ``tau`` < 0.
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
        """Torque command [N m] (CST), limited to k_t i_max.

        Parameters
        ----------
        mode : int
            ``Mode.CST`` only.
        value : complex | float
            [N m] the torque command.
        computed_one_sync_ago : bool, optional
            Unused.

        Raises
        ------
        ValueError
            If ``mode`` is not ``Mode.CST``.
        """
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
        """Over h [s]: ``held`` = mean of k_t i_q, i_ref + (i_q - i_ref) exp(-s/tau) for 0 <= s < h.

        Parameters
        ----------
        h : float
            [s] the step.
        t : float
            [s] the time at its start.
        """
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

    Parameters
    ----------
    p : DynoPreset
        The dyno preset.
    network : canopen.Network
        The canopen network.
    motor : Axis
        The motor under test's axis.
    ratings : Ratings
        Its ratings.

    Returns
    -------
    list[EmulatedNode]
        [motor drive, encoder, load machine drive].
    """
    rated = load_ratings(p, ratings).as_stored()  # its torque = k_t i_q agrees with 0x6076, 0x6075
    machine = LoadMachineAxis(
        motor,
        k_t=rated.rated_torque / rated.rated_current,
        i_max=rated.max_current_permille / 1000.0 * rated.rated_current,
        tau=p.load_torque_lag,
    )
    motor.load = _shaft_load(load_torque(p.load), machine)
    shaft = Shaft(motor, sources=(machine,), period=p.period)
    drive = EmulatedDrive(p.drive_node, network, motor, period=p.period, shaft=shaft)
    drive.rate(ratings, counts_per_rev=p.counts_per_rev)
    encoder = EmulatedEncoder(p.encoder_node, network, shaft, period=p.period)
    encoder.write(cia406.ENCODER_RESOLUTION, 0, p.counts_per_rev)
    load = EmulatedDrive(p.load_node, network, machine, period=p.period, shaft=shaft)
    load.rate(rated, counts_per_rev=p.counts_per_rev)
    # CST selected where the drive has no voltage mode (the load machine, the IM's FOC drive)
    for d in (drive, load):
        if Mode.VOLTAGE not in d.axis.modes:
            d.write(cia.MODES_OF_OPERATION, 0, Mode.CST)
            d.write(cia.MODES_DISPLAY, 0, Mode.CST)
    return [drive, encoder, load]
