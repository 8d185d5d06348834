"""A study loaded: its TOML file read and checked (``rig.sweep.spec``), then every value checked
against the base as a worker would run it (``rig.sweep.point``). Apart from the spec, so that the
point imports the spec and the spec nothing of the point."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from drivers.files import read_toml
from rig.sweep.point import check_values, default_metrics
from rig.sweep.spec import SweepSpec, spec_from_doc

__all__ = ["load_spec"]


def load_spec(path: str | Path) -> SweepSpec:
    """Load ``path`` and check it, every value against the base included (ConfigError naming the
    file, the key and the value); the metrics default to the base's.

    Parameters
    ----------
    path : str | Path
        The study's TOML file.

    Returns
    -------
    SweepSpec
        The checked study.
    """
    p = Path(path)
    spec = spec_from_doc(read_toml(p, what="sweep specification"), str(p))
    spec = replace(spec, metrics=spec.metrics or default_metrics(spec))
    check_values(spec)
    return spec
