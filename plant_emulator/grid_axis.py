"""The physics behind an emulated grid converter (``plant_emulator.axes``' interface): the RL load
with source voltage of the dq-current paper, in the stationary frame (``StationaryRLConverter``
with no internal delay: the CAN timing provides T_d).
"""

from __future__ import annotations

import cmath
import math

from drivers.maps.cia import Mode
from plant_emulator.axes import Axis
from plant_emulator.rl_dq import RLParams, StationaryRLConverter

__all__ = ["GridAxis"]


class GridAxis(Axis):
    """RL load with a rotating source (Table IV) behind the converter; mode -2 (dq voltage).

    Parameters
    ----------
    rl : RLParams
        The RL load and its converter (Table IV).
    omega_k : float
        [rad/s] the source's (grid's) frequency.
    source : complex, optional
        [V] the source's dq voltage.
    u_max : float, optional
        [V] the converter's voltage limit.
    hold_angle : str, optional
        "middle": a reference is turned with the angle half a period on (else its sample's).
    """

    modes = (Mode.DQ_VOLTAGE,)

    def __init__(
        self,
        rl: RLParams,
        *,
        omega_k: float,
        source: complex = 0j,
        u_max: float = math.inf,
        hold_angle: str = "middle",
    ) -> None:
        self.rl = RLParams(rl.r1, rl.l1, rl.ts, 1.0)  # the CAN timing makes the delay
        self.converter = StationaryRLConverter(self.rl, u_max=u_max, hold_angle=hold_angle)
        self.omega_k = omega_k
        self.source = source
        self._u_ab = 0j
        self._open = False  # the power stage off: its switches open (``coast``)
        self._theta_samples = (0.0, 0.0)  # frame angle at the previous and the latest SYNC

    def latch(self) -> None:
        self._theta_samples = (self._theta_samples[1], self.converter.theta)

    def set_command(self, mode: int, value: complex | float, *, computed_one_sync_ago: bool = False) -> None:
        """dq voltage reference [V]: turned to alpha-beta with the angle of the sample it was
        computed from (plus half a period with ``hold_angle="middle"``), as the modulator would.

        Parameters
        ----------
        mode : int
            ``Mode.DQ_VOLTAGE`` only.
        value : complex | float
            [V] the dq voltage reference.
        computed_one_sync_ago : bool, optional
            Computed from the sample one SYNC before the last.

        Raises
        ------
        ValueError
            If ``mode`` is not ``Mode.DQ_VOLTAGE``.
        """
        if mode != Mode.DQ_VOLTAGE:
            raise ValueError(f"grid axis has only mode {Mode.DQ_VOLTAGE}, got {mode}")
        theta = self._theta_samples[0 if computed_one_sync_ago else 1]
        now = self.converter.theta
        self.converter.theta = theta
        self._u_ab = self.converter.modulate(complex(value), self.omega_k)
        self.converter.theta = now
        self._open = False

    def coast(self) -> None:
        """Power stage off: its switches open. With the DC link above the source's line-to-line
        peak (|source| <= u_max = U_DC/sqrt(3): 566 V < 700 V in Table IV) the bridge's diodes
        block, and the inductor's current, forced into the DC link, is gone within the period
        (L di/dt ~ -U_DC: 32 A in 0.3 ms): here at once; none flows after it. (Zero voltage
        instead would short the grid through L1: 170 A.)"""
        self._u_ab = 0j
        self._open = True

    def reset(self) -> None:
        self.converter.i_ab = 0j
        self.converter.theta = 0.0
        self._u_ab = 0j

    def advance(self, h: float, t: float) -> None:
        if h <= 0.0:
            return
        if self._open:  # no current; the frame (the grid's angle) turns on
            c = self.converter
            c.i_ab = 0j
            c.theta = math.remainder(c.theta + self.omega_k * h, math.tau)
            return
        self.converter.advance(self._u_ab, self.omega_k, h, self.source)

    @property
    def i_dq(self) -> complex:
        """dq current at the present instant [A]."""
        return self.converter.i_ab * cmath.exp(-1j * self.converter.theta)

    @property
    def position(self) -> float:
        return self.converter.theta

    @property
    def velocity(self) -> float:
        return self.omega_k

    @property
    def current(self) -> float:
        return abs(self.converter.i_ab)
