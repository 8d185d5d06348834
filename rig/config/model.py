"""The model (3.5) a configuration names (``[controller] design = "FILE"``), read at load:
``identification.json`` (``rig identify``'s, in its run directory), a ``rig design dtsm --json``
file or a ``rig tune --json`` one (what each holds: ``rig.identify.model_file``, which writes
the first); ``read_model`` takes any of them, or a run directory holding identification.json.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from drivers.files import read_json

__all__ = ["FILE", "Model", "read_model"]

FILE = "identification.json"


@dataclass(frozen=True)
class Model:
    """(3.5) as read from a file: a_m [1/s], b_m, the input u is ("voltage" | "torque"), dt [s]
    of the data or the design, lam [1/s] of a design (None: an identification)."""

    a_m: float  #: [1/s] of (3.5)
    b_m: float  #: of (3.5), per unit of the input
    input: str  #: "voltage" or "torque"
    dt: float  #: [s] the data's or the design's period
    lam: float | None  #: [1/s] a design's lambda (None: an identification)
    source: str  #: the file it came from
    law: str | None = None  #: a ``rig tune`` design: the ``[controller] kind`` it is for
    params: dict[str, Any] | None = None  #: a ``rig tune`` design: the law's parameters


def _number(doc: dict[str, Any], key: str, where: str) -> float:
    v = doc.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ConfigError(f"{where}: {key} = {v!r}: expected a finite number")
    return float(v)


def read_model(path: str | Path, *, where: str = "") -> Model:
    """The model in ``path``: identification.json, a ``rig design dtsm --json`` file, or a run
    directory with identification.json. ConfigError naming ``where`` (what named the file: a
    key, an option), the file and the key.

    Parameters
    ----------
    path : str | Path
        identification.json, a ``rig design dtsm --json`` file, or a run directory.
    where : str, optional
        What named the file (a key, an option), in errors.

    Returns
    -------
    Model
        The model.

    Raises
    ------
    ConfigError
        If the file cannot be read or lacks a key (``where``, file and key named).
    """
    p = Path(path)
    if p.is_dir():
        p = p / FILE
    before = f"{where}: " if where else ""
    try:
        doc = read_json(p, what="identification or design")
    except ConfigError as exc:
        raise ConfigError(f"{before}{exc}") from None
    at = f"{before}{p}"
    if not isinstance(doc, dict):
        raise ConfigError(f"{at}: not a JSON object (rig identify's {FILE} or rig design dtsm --json)")
    a_m, b_m = _number(doc, "a_m", at), _number(doc, "b_m", at)
    dt = _number(doc, "dt", at) if "dt" in doc else math.nan
    if "dt" in doc and not dt > 0.0:
        raise ConfigError(f"{at}: dt = {dt!r}: expected a period > 0 s")
    lam = _number(doc, "lam", at) if "lam" in doc else None
    source = doc.get("input", "voltage")
    if source not in ("voltage", "torque"):
        raise ConfigError(f"{at}: input = {source!r}: expected voltage or torque")
    law, params = doc.get("law"), doc.get("params")
    if law is not None and (not isinstance(law, str) or not isinstance(params, dict)):
        raise ConfigError(f"{at}: law = {law!r} with params = {params!r}: expected a kind and an object")
    if law is not None and "dt" not in doc:
        raise ConfigError(f"{at}: a design for {law!r} without dt (the period it was made for)")
    return Model(a_m, b_m, source, dt, lam, str(p), law, params)
