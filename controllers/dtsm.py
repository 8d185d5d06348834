"""Discrete-time sliding-mode control, eqs. (6.14), (6.15a), (6.15b) of the drives paper.

The controller works on the state x of the design model (for a servo, the error
vector e = x_ref - x of (7.28)); it knows nothing of references or units beyond
that. The step path is plain floats for n <= 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, Protocol

from controllers.design import DTSMDesign

__all__ = ["DTSM", "Compensator", "DTSMParams"]

Law = Literal["deadbeat", "bounded", "saturated", "relay"]
_LAWS = ("deadbeat", "bounded", "saturated", "relay")


class Compensator(Protocol):
    """A disturbance compensator: u_c,k from g_k (see ``controllers.compensators``)."""

    def step(self, g: float) -> float:
        """One step of the compensator.

        Parameters
        ----------
        g : float
            The sliding variable g_k.

        Returns
        -------
        float
            The compensational control u_c,k [control unit].
        """
        ...

    def reset(self) -> None:
        """Restore the initial state."""
        ...


@dataclass(frozen=True, slots=True)
class DTSMParams:
    """Parameters of the DTSM law.

    ``law`` selects:

    - ``"deadbeat"``: (6.14) u = -c A x - g/T, unbounded;
    - ``"bounded"``: (6.15a) u = -c A x - min{sigma, |g|/T} sgn(g);
    - ``"saturated"``: (6.15b) u = U0 sat((-c A x - g/T) / U0); the paper writes
      U0 sat{.} with the argument in control units, read here as sat of the
      argument normalised by U0 so that |u| <= U0. A finite ``u0`` clips the
      output of every law, compensation included;
    - ``"relay"``: u = -c A x - sigma sgn(g), the sampled discontinuous law
      (6.8). It chatters; it is here as the counter-example for the metrics.

    ``compensate`` says when a compensator (6.25) acts. The paper does not say how the
    compensators (6.30b), (6.35) combine with the bounded reaching of (6.15a): during reaching
    g_k is far from T d_k, (6.29) reads the reaching as a disturbance, and the second-order
    compensator winds up and diverges (a 100 rad/s step at sigma = 10 V, Fig. 9's set-up).
    ``"always"``: every step; ``"linear"``: only while (6.15a) is in its linear mode,
    |g_k| <= T sigma, and reset to zero otherwise, as (7.30c) does with its integral u_I.

    Raises
    ------
    ValueError
        If the law or ``compensate`` is unknown, the design has more than 2 states, sigma or u0
        is not > 0, or the relay law has no finite sigma.
    """

    design: DTSMDesign  #: delta model and sliding vector, (6.9), (6.16)
    law: Law = "bounded"  #: which control law, see above
    sigma: float = math.inf  #: reaching-control bound of (6.15a) / relay gain [control unit]
    u0: float = math.inf  #: output limit U0 of (6.15b) [control unit]
    compensate: Literal["always", "linear"] = "always"  #: when the compensator acts, see above

    def __post_init__(self) -> None:
        if self.law not in _LAWS:
            raise ValueError(f"law must be one of {_LAWS}, got {self.law!r}")
        if self.design.order > 2:
            raise ValueError(f"DTSM step supports n <= 2 states, design has {self.design.order}")
        if not self.sigma > 0.0:
            raise ValueError(f"sigma must be > 0, got {self.sigma!r}")
        if not self.u0 > 0.0:
            raise ValueError(f"u0 must be > 0, got {self.u0!r}")
        if self.compensate not in ("always", "linear"):
            raise ValueError(f"compensate must be 'always' or 'linear', got {self.compensate!r}")
        if self.law == "relay" and not math.isfinite(self.sigma):
            raise ValueError("the relay law needs a finite sigma")


@dataclass
class DTSM:
    """DTSM controller with an optional disturbance compensator (6.25).

    ``step(x1, x2)`` returns u_k and leaves g_k in ``self.g``.

    Parameters
    ----------
    params : DTSMParams
        The design and the law.
    compensator : Compensator, optional
        A disturbance compensator (6.30b) or (6.35), added to the law's output.
    """

    params: DTSMParams
    compensator: Compensator | None = None
    g: float = field(default=0.0, init=False)  #: last sliding variable g_k (6.10)
    #: the last step was in the law's linear region: (6.14) and (6.15b) below U0, (6.15a) with
    #: |g|/T <= sigma; never for the relay (6.8) while g != 0 (its sign term is the whole reaching)
    linear: bool = field(default=True, init=False)

    def __post_init__(self) -> None:
        d = self.params.design
        c = (*d.c_delta, 0.0)
        k = (*d.c_delta_A_delta, 0.0)
        self._c1, self._c2 = c[0], c[1]
        self._k1, self._k2 = k[0], k[1]
        self._inv_dt = 1.0 / d.dt
        self._law = _LAWS.index(self.params.law)
        self._sigma = self.params.sigma
        self._u0 = self.params.u0
        self._linear_only = self.params.compensate == "linear"

    def reset(self) -> None:
        """Restore the initial state (and the compensator's)."""
        self.g = 0.0
        self.linear = True
        if self.compensator is not None:
            self.compensator.reset()

    def step(self, x1: float, x2: float = 0.0) -> float:
        """One control update from the state x_k = [x1, x2].

        Parameters
        ----------
        x1 : float
            First state.
        x2 : float
            Second state (ignored for n = 1).

        Returns
        -------
        float
            The control u_k [control unit], |u_k| <= u0.
        """
        g = self._c1 * x1 + self._c2 * x2
        self.g = g
        u_eq = -(self._k1 * x1 + self._k2 * x2)
        law = self._law
        linear = True
        if law == 0:  # (6.14)
            u = u_eq - g * self._inv_dt
        elif law == 1:  # (6.15a)
            reach = abs(g) * self._inv_dt
            if reach > self._sigma:
                reach, linear = self._sigma, False
            u = u_eq - reach if g > 0.0 else u_eq + reach
        elif law == 2:  # (6.15b), saturated below after compensation
            u = u_eq - g * self._inv_dt
        else:  # relay, (6.8) sampled
            u = u_eq - (self._sigma if g > 0.0 else -self._sigma if g < 0.0 else 0.0)
            linear = g == 0.0
        comp = self.compensator
        if comp is not None:
            if self._linear_only and abs(g) * self._inv_dt > self._sigma:
                comp.reset()  # reaching: no compensation, as u_I of (7.30c)
            else:
                u += comp.step(g)
        if u > self._u0:
            self.linear = False
            return self._u0
        if u < -self._u0:
            self.linear = False
            return -self._u0
        self.linear = linear
        return u
