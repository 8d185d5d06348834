"""Pure discrete-time controllers (numpy and scipy only; no I/O, no clock, no logging).

Every equation cites its number in the papers of ``../shared/papers``.
"""

from controllers.cascade import Cascade, CascadeLoop, CascadeLoopParams
from controllers.compensators import FirstOrderCompensator, SecondOrderCompensator
from controllers.design import DTSMDesign, design_dtsm, lambda_delta
from controllers.discretize import delta_model, zoh
from controllers.dtsm import DTSM, DTSMParams
from controllers.idtsm import IDTSM, IDTSMParams
from controllers.pi import PI, PIParams
from controllers.position_servo import PositionServo, PositionServoParams

__all__ = [
    "DTSM",
    "IDTSM",
    "PI",
    "Cascade",
    "CascadeLoop",
    "CascadeLoopParams",
    "DTSMDesign",
    "DTSMParams",
    "FirstOrderCompensator",
    "IDTSMParams",
    "PIParams",
    "PositionServo",
    "PositionServoParams",
    "SecondOrderCompensator",
    "delta_model",
    "design_dtsm",
    "lambda_delta",
    "zoh",
]
