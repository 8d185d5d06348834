"""A run's configuration, read from its TOML file and checked once, at load (``load_config``).

``schema`` holds the file's tables as typed dataclasses, ``load`` the loader; ``axes`` the axes' tables;
``controller`` and ``emulator`` the ``[controller]`` and ``[emulator]`` tables; ``checks`` and
``rules`` the value rules; ``params`` the one typed NAME=VALUE parser (``--param``). Above
``rig.laws`` (a ``[controller]`` table's keys are its law's parameters), below ``rig.host``
(which builds a run from a configuration that is valid).

The names below are ``schema``'s and ``load``'s (``load_config``, ``rig_config``), imported on
first use (PEP 562), so that a command line that only parses ``--param`` (``rig.config.params``)
does not load the whole schema.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rig.config.load import (
        load_config as load_config,
    )
    from rig.config.load import (
        rig_config as rig_config,
    )
    from rig.config.schema import (
        ABORT_CONNECTION as ABORT_CONNECTION,
    )
    from rig.config.schema import (
        AXIS_KINDS as AXIS_KINDS,
    )
    from rig.config.schema import (
        AxisConfig as AxisConfig,
    )
    from rig.config.schema import (
        AxisLimits as AxisLimits,
    )
    from rig.config.schema import (
        AxisUnits as AxisUnits,
    )
    from rig.config.schema import (
        BusConfig as BusConfig,
    )
    from rig.config.schema import (
        ControllerConfig as ControllerConfig,
    )
    from rig.config.schema import (
        EmulatorConfig as EmulatorConfig,
    )
    from rig.config.schema import (
        FaultsConfig as FaultsConfig,
    )
    from rig.config.schema import (
        Override as Override,
    )
    from rig.config.schema import (
        ReferenceConfig as ReferenceConfig,
    )
    from rig.config.schema import (
        RigConfig as RigConfig,
    )
    from rig.config.schema import (
        RunConfig as RunConfig,
    )
    from rig.config.schema import (
        replace_axis as replace_axis,
    )

__all__ = [
    "ABORT_CONNECTION",
    "AXIS_KINDS",
    "AxisConfig",
    "AxisLimits",
    "AxisUnits",
    "BusConfig",
    "ControllerConfig",
    "EmulatorConfig",
    "FaultsConfig",
    "Override",
    "ReferenceConfig",
    "RigConfig",
    "RunConfig",
    "load_config",
    "replace_axis",
    "rig_config",
]


def __getattr__(name: str) -> Any:
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    home = "load" if name in ("load_config", "rig_config") else "schema"
    value = globals()[name] = getattr(importlib.import_module(f"{__name__}.{home}"), name)
    return value
