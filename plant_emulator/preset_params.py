"""The presets' parameters (``plant_emulator.presets``): a dataclass per preset, every field a key
with its unit, meaning and range (``drivers.schema.key``), and ``preset_params`` to set them by name.

Below the devices: a device profile checks its ``[physics.params]`` here at load
(``plant_emulator.device_profile``), and the presets build the devices from them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

from drivers.schema import MAX_PERIOD, MIN_PERIOD, Refused, key
from plant_emulator.dc_motor import DCMotorParams
from plant_emulator.induction_motor import ImParams
from plant_emulator.parameters import node_key, profile_text, require_nodes, with_params

__all__ = [
    "DC_COULOMB",
    "DC_VISCOUS",
    "PRESETS",
    "DcServoPreset",
    "DynoPreset",
    "GridConverterPreset",
    "ImDrivePreset",
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
    return key("none", "N m", "load torque of time, drivers.profiles (e.g. sine:5:1)", check=profile_text)


@dataclass(frozen=True)
class DcServoPreset:
    """Parameters of ``dc-servo`` (SI; see the module docstring).

    Raises
    ------
    Refused
        If the friction leaves no room in ``a_m``.
    """

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
    """Parameters of ``grid-converter`` (SI; see the module docstring).

    Raises
    ------
    Refused
        If ``ratio``/``f_line`` is no period the toolkit runs.
    """

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
        "emulator-internal load torque T_ext of time (drivers.profiles)",
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

    Parameters
    ----------
    name : str
        A preset (``PRESETS``).
    params : Mapping[str, object] | Any, optional
        Typed values by name, or the preset's dataclass built already (None: the defaults).

    Returns
    -------
    Any
        The preset's dataclass.

    Raises
    ------
    ValueError
        If the preset is unknown, or a parameter is refused (``with_params``).
    """
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; known: {', '.join(PRESETS)}")
    return with_params(PRESETS[name], params)


def preset_period(name: str, params: Mapping[str, object] | Any = None) -> float:
    """The SYNC period [s] preset ``name`` runs at, with ``params`` applied.

    Parameters
    ----------
    name : str
        A preset (``PRESETS``).
    params : Mapping[str, object] | Any, optional
        Typed values by name, or the preset's dataclass built already.

    Returns
    -------
    float
        [s] the SYNC period.
    """
    return float(preset_params(name, params).period)
