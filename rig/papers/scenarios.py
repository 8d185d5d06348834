"""Closed-loop simulations of the drives paper's experiments, controller against physics.

Lock-step and deterministic: one controller step, then one exact plant step
per sample. These join ``controllers`` and ``plant_emulator`` without a bus;
the over-the-wire runs (later issues) must give the same trajectories. One module a
scenario, each a dataclass of its options (the paper's values by default) and a function
that runs it: ``rig.papers.servo_scenario`` (the DC position servo, section VII.B),
``rig.papers.speed_scenario`` (the speed loop under a disturbance, Fig. 9) and
``rig.papers.cascade_scenario`` (the IM cascade, section VII.D); the signals they return in
``rig.papers.trajectory``.
"""

from __future__ import annotations

from rig.papers.cascade_scenario import CascadeScenario, cascade_run
from rig.papers.servo_scenario import ServoScenario, position_servo_run
from rig.papers.speed_scenario import SpeedScenario, speed_loop_run
from rig.papers.trajectory import Trajectory

__all__ = [
    "CascadeScenario",
    "ServoScenario",
    "SpeedScenario",
    "Trajectory",
    "cascade_run",
    "position_servo_run",
    "speed_loop_run",
]
