"""Pure discrete-time controllers (numpy and scipy only; no I/O, no clock, no logging).

Every equation cites its number in the papers of ``../shared/papers``.

The names below are imported on first use (PEP 562): a law's module imports only what it needs.
"""

from __future__ import annotations

import importlib
from typing import Any

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

_WHERE = {
    "Cascade": "cascade",
    "CascadeLoop": "cascade",
    "CascadeLoopParams": "cascade",
    "FirstOrderCompensator": "compensators",
    "SecondOrderCompensator": "compensators",
    "DTSMDesign": "design",
    "design_dtsm": "design",
    "lambda_delta": "design",
    "delta_model": "discretize",
    "zoh": "discretize",
    "DISMC": "dismc",
    "DISMCParams": "dismc",
    "dismc_lqr_gain": "dismc",
    "lmi_28_holds": "dismc",
    "DTSM": "dtsm",
    "DTSMParams": "dtsm",
    "IDTSM": "idtsm",
    "IDTSMParams": "idtsm",
    "solve_model_following": "model_following",
    "PI": "pi",
    "PIParams": "pi",
    "PositionServo": "position_servo",
    "PositionServoParams": "position_servo",
}


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = globals()[name] = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    return value  # kept: a submodule of the same name (estimate) does not shadow it
