"""The other side of the wire: emulated devices and the motor physics behind them.

The names below are imported on first use (PEP 562), so that importing one module of the
package (``plant_emulator.parameters`` for a command line's ``--param``) does not import scipy.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["DCMotor", "DCMotorParams", "Encoder", "LinearZOH", "ReducedDCMotor"]

_WHERE = {
    "DCMotor": "dc_motor",
    "DCMotorParams": "dc_motor",
    "ReducedDCMotor": "dc_motor",
    "Encoder": "encoder",
    "LinearZOH": "zoh",
}


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = globals()[name] = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    return value  # kept: a submodule of the same name (estimate) does not shadow it
