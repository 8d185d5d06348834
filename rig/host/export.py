"""``rig export``: a run directory's samples in the file formats other tools open.

The samples are read back from ``samples.csv`` (``rig.host.rundir.read_samples``: what a run
killed before its close left is there too) with each column's unit and meaning from
``columns.json``. Formats:

- ``mf4``: ASAM MDF 4 through asammdf (the optional ``export`` extra): one channel group whose
  master channel is ``t`` [s], one channel per other column with its unit and its meaning as
  the channel's comment; CANape, MDA, asammdf's GUI and MATLAB's ``mdfRead`` open it.
- ``parquet``: Apache Parquet through pyarrow (the ``export`` extra): one float64 column per
  column of samples.csv, each field's metadata ``unit`` and ``meaning``, the run's
  configuration in the table's metadata (``rig.config``); pandas, Polars, DuckDB and Spark read it.
- ``mat``: MATLAB, as the recorder writes ``samples.mat`` at a run's close (``write_mat``).
- ``csv``: the columns as in samples.csv, whole rows only.

A format whose package is not installed is a ``ConfigError`` that says what to install.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from drivers.errors import ConfigError
from drivers.files import read_json
from rig.host.rundir import read_samples
from rig.host.storage import write_atomic, write_mat

__all__ = ["FORMATS", "export_run"]

#: format -> the extension of its file
FORMATS = {"mf4": ".mf4", "parquet": ".parquet", "mat": ".mat", "csv": ".csv"}


def _docs(run_dir: Path, columns: list[str]) -> dict[str, dict[str, str]]:
    """columns.json's unit and meaning of each column ("" where it says none)."""
    path = run_dir / "columns.json"
    given = read_json(path, what="columns' units") if path.exists() else {}
    if not isinstance(given, dict):
        raise ConfigError(f"{path}: not a JSON object of columns")
    docs = {}
    for c in columns:
        d = given.get(c)
        d = d if isinstance(d, dict) else {}
        docs[c] = {"unit": str(d.get("unit", "")), "meaning": str(d.get("meaning", ""))}
    return docs


def _needs(module: str, fmt: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise ConfigError(
            f"rig export --format {fmt} needs {module.split('.', maxsplit=1)[0]}: "
            "python -m pip install 'drive-rig[export]'"
        ) from None


def export_run(run_dir: str | Path, fmt: str, output: str | Path | None = None) -> Path:
    """Write the samples of ``run_dir`` in format ``fmt``.

    Parameters
    ----------
    run_dir : str | Path
        The run directory.
    fmt : str
        A key of ``FORMATS``.
    output : str | Path | None
        The file to write (None: beside the run directory, its name with the format's extension);
        an existing file is replaced whole, never the run's samples.csv.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ConfigError
        Naming what is wrong: an unknown format, a package not installed, no samples, output the
        run's samples.csv.
    """
    d = Path(run_dir)
    if fmt not in FORMATS:
        raise ConfigError(f"rig export --format {fmt}: expected one of {', '.join(FORMATS)}")
    config, table = read_samples(d)
    columns = list(table)
    data = np.column_stack([table[c] for c in columns]) if columns else np.empty((0, 0))
    docs = _docs(d, columns)
    out = Path(output) if output is not None else d.with_name(d.name + FORMATS[fmt])
    if out.resolve() == (d / "samples.csv").resolve():
        raise ConfigError(f"{out}: is the run's samples.csv: give --output another file")
    if fmt == "mf4":
        _mf4(out, columns, data, docs, d.name)
    elif fmt == "parquet":
        _parquet(out, columns, data, docs, config)
    elif fmt == "mat":
        write_atomic(out, lambda f: write_mat(f, columns, lambda i: data[:, i], docs), binary=True)
    else:
        body = "".join(",".join(map(repr, map(float, row))) + "\n" for row in data)
        write_atomic(out, lambda f: f.write(",".join(columns) + "\n" + body))
    return out


def _mf4(out: Path, columns: list[str], data: np.ndarray, docs: dict[str, dict[str, str]], name: str) -> None:
    asammdf = _needs("asammdf", "mf4")
    if "t" not in columns:
        raise ConfigError(f"{out.parent}: samples.csv has no column t: MF4 needs the time")
    t = data[:, columns.index("t")]
    signals = [
        asammdf.Signal(
            samples=data[:, i], timestamps=t, name=c, unit=docs[c]["unit"], comment=docs[c]["meaning"]
        )
        for i, c in enumerate(columns)
        if c != "t"
    ]
    mdf = asammdf.MDF(version="4.10")
    try:
        mdf.append(signals, comment=f"drive-rig run {name}")
        saved = mdf.save(out.with_name(f".{out.stem}.tmp.mf4"), overwrite=True)  # it keeps .mf4
        saved.replace(out)
    finally:
        mdf.close()


def _parquet(
    out: Path, columns: list[str], data: np.ndarray, docs: dict[str, dict[str, str]], config: dict[str, Any]
) -> None:
    pa = _needs("pyarrow", "parquet")
    pq = _needs("pyarrow.parquet", "parquet")
    fields = [
        pa.field(c, pa.float64(), metadata={"unit": docs[c]["unit"], "meaning": docs[c]["meaning"]})
        for c in columns
    ]
    schema = pa.schema(fields, metadata={"rig.config": json.dumps(config)})
    table = pa.Table.from_arrays([pa.array(data[:, i]) for i in range(len(columns))], schema=schema)
    tmp = out.with_name(f".{out.name}.tmp")
    pq.write_table(table, tmp)
    tmp.replace(out)
