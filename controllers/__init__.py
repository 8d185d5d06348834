"""Pure discrete-time controllers (numpy and scipy only; no I/O, no clock, no logging).

Every equation cites its number in the papers of ``../shared/papers``.
"""

from controllers.cascade import Cascade, CascadeLoop, CascadeLoopParams
from controllers.compensators import FirstOrderCompensator, SecondOrderCompensator
from controllers.design import DTSMDesign, design_dtsm, lambda_delta
from controllers.discretize import delta_model, zoh
from controllers.dismc import DISMC, DISMCParams, dismc_lqr_gain, lmi_28_holds
from controllers.dtsm import DTSM, DTSMParams
from controllers.idtsm import IDTSM, IDTSMParams
from controllers.model_following import solve_model_following
from controllers.pi import PI, PIParams
from controllers.position_servo import PositionServo, PositionServoParams

__all__ = [
    "DISMC",
    "DTSM",
    "IDTSM",
    "PI",
    "Cascade",
    "CascadeLoop",
    "CascadeLoopParams",
    "DISMCParams",
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
    "dismc_lqr_gain",
    "lambda_delta",
    "lmi_28_holds",
    "solve_model_following",
    "zoh",
]
