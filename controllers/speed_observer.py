"""Speed from a quantised encoder: a model-based observer of (3.5) with a disturbance state.

The drives paper estimates the speed by the Euler backward difference (Fig. 24, ref. [28]):
with 4096 counts/rev at T = 0.4 ms its quantum is 2 pi/4096/T = 3.8 rad/s, larger than the
servo's rho = 0.5 rad/s of (7.30c), so the switching integral never settles and the command
dithers. This observer uses the model the law is designed for instead.

Model: (3.5) with the position (3.7) and a constant disturbance acceleration d (the load
torque and Coulomb friction over J, as f(t) of (7.28)),

    d theta/dt = omega,  d omega/dt = -a_m omega + b_m u + d,  d d/dt = 0,

made exact for a held u by ``zoh`` (the ZOH of (6.9)'s derivation): x_{k+1} = Phi x_k +
Gamma u_k, x = [theta, omega, d]. The law's own command is the input; the drive applies it
``delay`` periods later. Predictor-corrector ("current") form, the measurement y_k = theta_k:

    x^_k     = x-_k + L (y_k - C x-_k)            (correct with this sample's position)
    x-_{k+1} = Phi x^_k + Gamma u_{k-delay}       (predict the next)

with L placed (Ackermann, ``acker``) so that the error x_{k+1} - x^_{k+1} obeys
e_{k+1} = (Phi - L C Phi) e_k with all three poles at exp(-bandwidth T). The d state
makes the speed estimate unbiased under a constant load. Pure: no I/O, SI units.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from controllers.design import acker
from controllers.discretize import zoh

__all__ = ["SpeedObserver"]


class SpeedObserver:
    """The observer of the module docstring.

    Parameters
    ----------
    a_m : float
        Plant pole a_m of (3.5) [1/s].
    b_m : float
        Plant gain b_m of (3.5) [rad/s^2 per unit of u], non-zero.
    dt : float
        Sample period T [s].
    bandwidth : float
        The observer's poles, all at exp(-bandwidth T) [rad/s], > 0.
    delay : int
        Periods (0..10) after which the drive applies a command.

    Raises
    ------
    ValueError
        If the bandwidth, the delay or the model is out of range.
    """

    def __init__(self, a_m: float, b_m: float, *, dt: float, bandwidth: float, delay: int = 0) -> None:
        if not (math.isfinite(bandwidth) and bandwidth > 0.0):
            raise ValueError(f"observer bandwidth must be > 0 rad/s, got {bandwidth!r}")
        if not 0 <= delay <= 10:
            raise ValueError(f"observer delay must be 0..10 periods, got {delay!r}")
        if not (math.isfinite(a_m) and math.isfinite(b_m) and b_m != 0.0):
            raise ValueError(f"observer model: a_m = {a_m!r}, b_m = {b_m!r}: finite, b_m != 0")
        A = np.array([[0.0, 1.0, 0.0], [0.0, -a_m, 1.0], [0.0, 0.0, 0.0]])
        B = np.array([0.0, b_m, 0.0])
        phi, gamma = zoh(A, B, dt=dt)
        c = np.array([1.0, 0.0, 0.0])
        pole = math.exp(-bandwidth * dt)
        gain = acker(phi.T, (c @ phi).reshape(3), [pole, pole, pole])
        self.phi = [list(map(float, row)) for row in phi]  #: floats: a step is ~40 operations
        self.gamma = [float(g) for g in gamma.reshape(3)]
        self.gain = [float(g) for g in gain]
        self._commands: deque[float] = deque([0.0] * delay, maxlen=delay) if delay else deque()
        self.delay = delay
        self._x: list[float] | None = None  #: the prediction x-_k (None: no sample yet)
        self._u = 0.0  #: the latest command [unit of u]: what the drive holds without a new one
        self.theta = self.omega = self.disturbance = 0.0  #: the corrected estimate x^_k

    def update(self, theta: float) -> float:
        """Correct the estimate with this sample's position.

        The first sample starts the observer at rest there.

        Parameters
        ----------
        theta : float
            The measured position [rad].

        Returns
        -------
        float
            The speed estimate [rad/s].
        """
        x = self._x if self._x is not None else [theta, 0.0, 0.0]
        r = theta - x[0]
        g = self.gain
        self.theta, self.omega, self.disturbance = x[0] + g[0] * r, x[1] + g[1] * r, x[2] + g[2] * r
        return self.omega

    def command(self, u: float) -> None:
        """Predict the next sample with the command the drive applies now.

        Parameters
        ----------
        u : float
            The command sent this period (applied ``delay`` periods later) [unit of u].
        """
        self._u = u
        if self.delay:
            applied = self._commands[0]
            self._commands.append(u)
        else:
            applied = u
        xh = (self.theta, self.omega, self.disturbance)
        p, gm = self.phi, self.gamma
        self._x = [
            p[0][0] * xh[0] + p[0][1] * xh[1] + p[0][2] * xh[2] + gm[0] * applied,
            p[1][0] * xh[0] + p[1][1] * xh[1] + p[1][2] * xh[2] + gm[1] * applied,
            p[2][0] * xh[0] + p[2][1] * xh[1] + p[2][2] * xh[2] + gm[2] * applied,
        ]

    def hold(self, u: float) -> None:
        """The drive holds ``u`` from now on instead of the latest command (a host that sent it
        without a step: ``coast`` predicts with it).

        Parameters
        ----------
        u : float
            The command the drive holds [unit of u].
        """
        self._u = u

    def coast(self, periods: int) -> None:
        """Predict over ``periods`` periods that brought no sample, the drive holding the latest
        command (a cycle the host skipped or whose sample came late): each an uncorrected
        prediction, x^_k = x-_k, then x-_(k+1) = Phi x^_k + Gamma u, so the next sample corrects
        an estimate that has moved with the shaft.

        Parameters
        ----------
        periods : int
            Periods without a sample (0: nothing).
        """
        if self._x is None:
            return
        for _ in range(periods):
            self.theta, self.omega, self.disturbance = self._x
            self.command(self._u)
