"""The drive and motor behind the emulated Modbus inverter's registers, and its communication-loss trip.

A V/f drive with a linear speed ramp (``accel`` rad/s^2) feeding an induction motor
whose speed follows the ramp with the slip of the load torque:
omega = omega_ramp - sgn(omega_ramp) slip T_L / T_rated, smoothed with ``tau`` [s];
the current is I_0 + (I_rated - I_0) |T_L| / T_rated. ``step(dt)`` advances it.

Communication loss: like a real drive's fieldbus supervision (ABB's communication loss
time and action, Siemens' fieldbus monitoring time, Delta's time-out detection), a
running inverter that has processed no request for ``comm_loss_timeout`` [s] of its own
clock trips with fault 0x6681 (ABB 'EFB comm loss') and stops by ``comm_loss_action``:
``ramp`` on its own ramp (``accel``), or ``coast`` (modulation off: no current, the speed
decays freely with ``coast_tau`` [s]). The default 0.5 s is 50 periods of a 10 ms host
cycle, far above any jitter of a host that polls every cycle, and short enough that a
dead host leaves the motor under way for half a second at most before the stop starts.
``comm_loss_timeout = inf`` turns the supervision off. The clock is the model's ``t``:
on the wall clock when the server runs the physics, one host period per cycle in
lock-step, so a host that polls every cycle leaves a gap of one period in both.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from drivers.maps import ModbusMap
from drivers.schema import key

__all__ = ["COMM_LOSS", "COMM_LOSS_ACTIONS", "OVERSPEED", "InverterModel", "no_load"]

log = logging.getLogger(__name__)
OVERSPEED = 0x7310  # fault code used by the emulator for over-speed (ABB 7310 'overspeed')
COMM_LOSS = 0x6681  # communication loss of the embedded fieldbus (ABB 6681 'EFB comm loss')
COMM_LOSS_ACTIONS = ("ramp", "coast")


def no_load(t: float) -> float:
    """No load torque: the model's default ``load``.

    Parameters
    ----------
    t : float
        [s] the model's time.

    Returns
    -------
    float
        0 [N m].
    """
    return 0.0


@dataclass
class InverterModel:
    """The drive and motor behind the registers (SI units): its parameters are its keys
    (``drivers.schema.key``, ``[emulator.inverter]``, checked by whoever reads them), the rest its
    state."""

    regmap: ModbusMap  #: the register map it answers with
    accel: float = key(100.0, "rad/s^2", "the speed ramp", gt=0.0)
    slip: float = key(5.0, "rad/s", "the speed drop at rated torque", ge=0.0)
    tau: float = key(0.05, "s", "the mechanical lag", gt=0.0)
    rated_torque: float = key(10.0, "N m", "the rated torque", gt=0.0)
    rated_current: float = key(8.0, "A", "the rated current", gt=0.0)
    no_load_current: float = key(2.5, "A", "the current without load", ge=0.0)
    max_speed: float = key(200.0, "rad/s", "the over-speed trip", gt=0.0)
    load: Callable[[float], float] = no_load  #: load torque [N m] of time [s]
    running: bool = False  #: the run command is in force
    fault: int = 0  #: the fault code (0: none)
    reference: float = 0.0  #: [rad/s] the speed reference
    ramp: float = 0.0  #: [rad/s] the ramp's set-point
    speed: float = 0.0  #: [rad/s] the shaft's speed
    current: float = 0.0  #: [A] the motor current
    t: float = 0.0  #: [s] the model's time
    comm_loss_timeout: float = key(
        0.5,
        "s",
        "trip if no request is processed this long while running (inf: off)",
        gt=0.0,
        finite=False,
        also={math.inf: "off"},
    )
    comm_loss_action: Literal["ramp", "coast"] = key("ramp", "", "the stop after a communication-loss trip")
    coast_tau: float = key(2.0, "s", "time constant of the free-running speed when coasting", gt=0.0)
    coasting: bool = False  #: modulation off after a coast stop, until the next run command
    last_request: float = 0.0  #: model time of the last request processed [s]

    def _supervise(self) -> None:
        """The communication-loss trip."""
        if self.running and not self.fault and self.t - self.last_request > self.comm_loss_timeout:
            log.warning(
                "inverter: no request for %.3g s (comm_loss_timeout %.3g s): communication-loss trip, %s",
                self.t - self.last_request,
                self.comm_loss_timeout,
                self.comm_loss_action,
            )
            self.fault = COMM_LOSS
            self.running = False
            self.coasting = self.comm_loss_action == "coast"

    def step(self, dt: float) -> None:
        """Advance dt [s].

        Parameters
        ----------
        dt : float
            [s] the step.
        """
        self.t += dt
        self._supervise()
        if self.running:
            self.coasting = False
        t_load = self.load(self.t)
        if self.coasting:  # modulation off: the motor runs down freely, the ramp output follows it
            self.speed *= math.exp(-dt / self.coast_tau)
            self.ramp = self.speed
            self.current = 0.0
        else:
            self._drive(dt, t_load)
        if abs(self.speed) > self.max_speed and not self.fault:
            log.warning("inverter: over-speed %.1f rad/s, trip", self.speed)
            self.fault = OVERSPEED
            self.running = False

    def _drive(self, dt: float, t_load: float) -> None:
        """The ramp towards the reference (zero when stopped or tripped) and the motor behind it."""
        target = self.reference if (self.running and not self.fault) else 0.0
        delta = max(-self.accel * dt, min(self.accel * dt, target - self.ramp))
        self.ramp += delta
        # a braking load (same sign as the speed) slows the motor by the slip; a driving one speeds it up
        goal = (
            self.ramp - math.copysign(1.0, self.ramp) * self.slip * t_load / self.rated_torque
            if self.ramp
            else 0.0
        )
        self.speed += (goal - self.speed) * (1.0 - math.exp(-dt / self.tau))
        excitation = self.no_load_current if (self.running or abs(self.ramp) > 0) and not self.fault else 0.0
        self.current = (
            excitation + (self.rated_current - self.no_load_current) * abs(t_load) / self.rated_torque
        )
