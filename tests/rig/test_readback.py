"""Reading a run's samples back at its close in chunks (``rig.host.readback``): the same numbers
as reading the whole file, in memory that does not grow with the run."""

from __future__ import annotations

import math
import os
import pathlib

import numpy as np
import pytest
import scipy.io

from rig.host.readback import Columns, Envelope, copy_text, read_rows
from rig.host.recorder import Recorder


def _csv(path: pathlib.Path, rows: np.ndarray, tail: str = "") -> int:
    text = "t,a,b\n" + "".join(",".join(map(repr, map(float, r))) + "\n" for r in rows) + tail
    path.write_text(text)
    return os.open(path, os.O_RDONLY)


def _rows(n: int) -> np.ndarray:
    k = np.arange(n)
    return np.column_stack([k * 1e-3, np.sin(k * 0.37), (-1.0) ** k * (1 + k % 7)])


@pytest.mark.parametrize("rows", [1, 7, 8192])
def test_the_rows_come_back_whole_in_chunks_without_a_torn_last_line(
    tmp_path: pathlib.Path, rows: int
) -> None:
    data = _rows(1000)
    fd = _csv(tmp_path / "s.csv", data, tail="0.5,1.0,2")  # a row torn by a full disk
    try:
        chunks = list(read_rows(fd, 3, 10**9, rows=rows))
        assert all(len(c) == rows for c in chunks[:-1])
        np.testing.assert_array_equal(np.concatenate(chunks), data)
        np.testing.assert_array_equal(np.concatenate(list(read_rows(fd, 3, 600))), data[:600])
        copied = bytearray()
        copy_text(fd, copied.extend)
        assert copied.decode() == (tmp_path / "s.csv").read_text().rsplit("\n", 1)[0] + "\n"
    finally:
        os.close(fd)


@pytest.mark.parametrize("chunk", [1, 13, 1000, 5000])
def test_the_envelope_keeps_each_buckets_extremes_whatever_the_chunks(chunk: int) -> None:
    data = _rows(4999)
    env = Envelope(len(data), 3, points=100)
    for i in range(0, len(data), chunk):
        env.add(data[i : i + chunk])
    rows = env.rows()
    size = math.ceil(4999 / 100)
    assert env.size == size and len(rows) == 2 * math.ceil(4999 / size)
    for b in range(0, len(rows), 2):
        bucket = data[b // 2 * size : (b // 2 + 1) * size]
        assert rows[b, 0] == rows[b + 1, 0] == bucket[0, 0]  # the bucket's first time
        np.testing.assert_array_equal(rows[b, 1:], bucket[:, 1:].min(axis=0))
        np.testing.assert_array_equal(rows[b + 1, 1:], bucket[:, 1:].max(axis=0))


def test_a_short_run_is_plotted_from_its_rows_themselves() -> None:
    data = _rows(300)
    env = Envelope(len(data), 3)
    env.add(data[:100])
    env.add(data[100:])
    np.testing.assert_array_equal(env.rows(), data)


def test_columns_come_back_one_at_a_time() -> None:
    data = _rows(1234)
    with Columns(2000, 3) as columns:  # room for more rows than came
        for i in range(0, 1234, 500):
            columns.add(data[i : i + 500])
        for c in range(3):
            np.testing.assert_array_equal(columns.column(c), data[:, c])


def test_the_recorders_close_writes_every_sample_to_mat_and_plots_the_envelope(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """20,000 rows of a chattering command: samples.mat holds every one, the plot's rows are at
    most 2 x 4,000 and reach the command's extremes."""
    plotted: list[np.ndarray] = []
    monkeypatch.setattr(Recorder, "PLOT", True)
    monkeypatch.setattr(Recorder, "plot", lambda self, data: plotted.append(data))
    rec = Recorder(tmp_path, "long", trace=False)
    rec.begin(["t", "reference", "measurement", "command"], {"t": {"unit": "s", "meaning": "time"}})
    n = 20_000
    for k in range(n):
        rec.sample([k * 1e-3, 1.0, math.sin(k * 1e-3), 10.0 if k % 2 else -10.0 - k * 1e-6])
    rec.close({"cycles": n})
    mat = scipy.io.loadmat(rec.dir / "samples.mat")
    assert mat["t"].shape == (1, n)
    np.testing.assert_array_equal(mat["command"][0, ::2], -10.0 - np.arange(0, n, 2) * 1e-6)
    assert str(mat["column_unit"]["t"][0, 0][0]) == "s"
    (data,) = plotted
    assert len(data) <= 2 * 4000
    assert data[:, 3].max() == 10.0 and data[:, 3].min() == -10.0 - (n - 2) * 1e-6
