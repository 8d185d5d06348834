"""``rig identify``: a_m and b_m of (3.5) from an experiment on the drive, or from a recorded run.

``estimate`` holds the estimator, ``experiment`` runs the excitation through the
host session like any other run. The names below come from ``estimate`` on first use, so that
importing a module of the package does not import the estimator (scipy.signal, scipy.stats);
``rig.identify.estimate`` is the function, as the name exported here, even once the module of
the same name is imported.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # what the names below are, for the type checker
    from rig.identify.estimate import (
        IdentificationError,
        IdentResult,
        estimate,
        excitation,
        virtual_experiment,
    )

__all__ = ["IdentResult", "IdentificationError", "estimate", "excitation", "virtual_experiment"]


class _Package(types.ModuleType):
    def __getattribute__(self, name: str) -> Any:
        if name in __all__:
            return getattr(importlib.import_module("rig.identify.estimate"), name)
        return super().__getattribute__(name)


sys.modules[__name__].__class__ = _Package
