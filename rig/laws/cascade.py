"""``cascade-position``: the position and speed loops of section VII.D (reconstructed (6.36), Table V).

The position loop runs every ``position_every`` cycles, the speed loop every cycle;
the speed loop's q-current reference is sent as the torque k_t i_q* (CST). Without
``speed_*`` and ``position_*`` parameters the loops are Table V's; with any of them (``rig
tune cascade-position``), each loop is Table V's with those fields replaced and T the run's
period (the position loop's: times ``position_every``); with k_t = 1 the speed loop's output
is the command itself, a torque in CST or a voltage in voltage mode.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from controllers.cascade import TABLE_V_POSITION, TABLE_V_SPEED, CascadeLoop, CascadeLoopParams
from drivers.base import Feedback
from drivers.schema import Refused, key
from rig.laws import drives_paper as drives
from rig.laws.base import SIGN_LAW, Law, LawParams, LawStep, Reference

__all__ = ["CascadeParams", "CascadePositionLaw"]


#: the fields of a loop a design gives (``CascadeLoopParams``), as speed_NAME and position_NAME
LOOP_FIELDS = ("c_s", "k_s", "k_r1", "k_r2", "k_int", "u0", "beta", "alpha")


def _loop_key(loop: str, name: str) -> Any:
    """``<loop>_<name>``: that field of ``CascadeLoopParams`` of a designed loop (None: Table V's)."""
    doc = f"a designed {loop} loop's {name} (Table V's symbols; none: Table V's loop)"
    allowed: dict[str, Any] = {
        "k_r1": {"gt": 0.0, "le": 1.0},
        "k_r2": {"ge": 0.0},
        "k_int": {"ge": 0.0},
        "u0": {"gt": 0.0},
        "beta": {"gt": 0.0},
        "alpha": {"ge": 0.0, "le": 1.0},
    }.get(name, {})
    return key(None, "", doc, **allowed)


@dataclass(frozen=True)
class CascadeParams(LawParams):
    """Table V's two loops, or designed ones (``rig tune cascade-position``)."""

    k_t: float = key(
        drives.B_W * drives.J_IM, "N m/A", "the torque per q current: b_w J of Table V", nonzero=True
    )
    position_every: int = key(2, "cycles", "the position loop's period (1 ms at 0.5 ms)", ge=1)
    speed_c_s: tuple[float, ...] | None = _loop_key("speed", "c_s")
    speed_k_s: tuple[float, ...] | None = _loop_key("speed", "k_s")
    speed_k_r1: float | None = _loop_key("speed", "k_r1")
    speed_k_r2: float | None = _loop_key("speed", "k_r2")
    speed_k_int: float | None = _loop_key("speed", "k_int")
    speed_u0: float | None = _loop_key("speed", "u0")
    speed_beta: float | None = _loop_key("speed", "beta")
    speed_alpha: float | None = _loop_key("speed", "alpha")
    position_c_s: tuple[float, ...] | None = _loop_key("position", "c_s")
    position_k_s: tuple[float, ...] | None = _loop_key("position", "k_s")
    position_k_r1: float | None = _loop_key("position", "k_r1")
    position_k_r2: float | None = _loop_key("position", "k_r2")
    position_k_int: float | None = _loop_key("position", "k_int")
    position_u0: float | None = _loop_key("position", "u0")
    position_beta: float | None = _loop_key("position", "beta")
    position_alpha: float | None = _loop_key("position", "alpha")

    def rules(self, period: float) -> None:
        """A designed loop's c_s and k_s have 1 or 2 entries each, as many, and c_s[0] is not 0.

        Parameters
        ----------
        period : float
            [s] the run's.

        Raises
        ------
        Refused
            If a rule is broken.
        """
        for loop in ("speed", "position"):
            c_s, k_s = getattr(self, f"{loop}_c_s"), getattr(self, f"{loop}_k_s")
            if c_s is None and k_s is None:
                continue
            if c_s is None or k_s is None or len(c_s) not in (1, 2) or len(k_s) != len(c_s):
                raise Refused(f"{loop}_c_s", c_s, f"and {loop}_k_s = {k_s!r} must both have 1 or 2 entries")
            if c_s[0] == 0.0:
                raise Refused(f"{loop}_c_s", c_s, "must not start with 0")

    def loop(self, name: str, table: CascadeLoopParams, dt: float) -> CascadeLoopParams:
        """The loop ``name`` ("speed" or "position"): ``table`` without designed fields, else
        ``table`` with them at ``dt`` [s].

        Parameters
        ----------
        name : str
            "speed" or "position".
        table : CascadeLoopParams
            Its table.
        dt : float
            [s] its period.

        Returns
        -------
        CascadeLoopParams
            The loop's parameters.
        """
        given = {
            k: getattr(self, f"{name}_{k}") for k in LOOP_FIELDS if getattr(self, f"{name}_{k}") is not None
        }
        return dataclasses.replace(table, dt=dt, **given) if given else table

    @property
    def designed(self) -> bool:
        """Any loop field given (``rig tune cascade-position``)."""
        return any(getattr(self, f"{n}_{k}") is not None for n in ("speed", "position") for k in LOOP_FIELDS)


class CascadePositionLaw(Law):
    """The reconstructed cascade (6.36) of section VII.D: position, speed and current loops.

    Parameters
    ----------
    params : CascadeParams
        Its parameters.
    period : float
        [s] the loop's.
    reference : Reference
        The position reference.
    """

    Params = CascadeParams
    error_unit = "rad"
    modes = (frozenset({"cst", "voltage"}),)
    position_reference = True
    internals = ("omega_ref", "i_q_ref", SIGN_LAW)

    def __init__(self, params: CascadeParams, *, period: float, reference: Reference) -> None:
        super().__init__(params, period=period, reference=reference)
        p = params
        if p.designed:
            self.position = CascadeLoop(p.loop("position", TABLE_V_POSITION, period * p.position_every))
            self.speed = CascadeLoop(p.loop("speed", TABLE_V_SPEED, period))
        else:
            self.position, self.speed = CascadeLoop(TABLE_V_POSITION), CascadeLoop(TABLE_V_SPEED)
        self._k = 0
        self._omega_ref = 0.0

    def sensitivity(self) -> tuple[float, float]:
        """The torque command's gradient in the boundary layers of the reconstructed (6.36): a
        loop's output moves per unit of its j-th measurement by
        |k_j| + k_r1 |c_j| / T + k_int T |c_j| / (|c_1| beta) (equivalent control, linear
        reaching, one step of the integral of sat(g / (c_1 beta))); the speed loop's (times
        k_t) per rad/s, and through the position loop's speed reference per rad.

        Returns
        -------
        tuple[float, float]
            (|du/dtheta|, |du/domega|).
        """
        pos, spd = self.position.params, self.speed.params

        def gain(p: CascadeLoopParams, j: int) -> float:
            c = abs(p.c_s[j])
            return abs(p.k_s[j]) + p.k_r1 * c / p.dt + p.k_int * p.dt * c / (abs(p.c_s[0]) * p.beta)

        g_w = self.params.k_t * gain(spd, 0)
        return (g_w * gain(pos, 0), g_w * (1.0 + gain(pos, 1)))

    def step(self, t: float, feedback: Sequence[Feedback]) -> LawStep:
        theta_r, _ = self.reference(t)
        fb = feedback[0]
        if self._k % self.params.position_every == 0:
            self._omega_ref = self.position.step(theta_r, fb.position, fb.velocity)
        self._k += 1
        i_q = self.speed.step(self._omega_ref, fb.velocity)
        sign = 0.0 if self.position.linear and self.speed.linear else 1.0
        return LawStep((self.params.k_t * i_q,), theta_r, fb.position, (self._omega_ref, i_q, sign))
