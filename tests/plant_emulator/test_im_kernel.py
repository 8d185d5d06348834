"""The induction motor's compiled inner loop is the same arithmetic as its Python: the numba
kernel against the uncompiled function over 1 s of a speed step with a load step, and the
emulator's IM preset at the speed the bench measures."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from drivers.maps.cia import Mode
from plant_emulator import im_kernel
from plant_emulator.induction_motor import ImAxis, ImParams


def test_numba_compiles_it() -> None:
    assert im_kernel.JIT is True  # numba is a dependency: the IM physics is compiled


def test_compiled_and_python_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled kernel and the same code run as Python, its current loops' step too."""
    axis = ImAxis(ImParams())
    axis.set_command(Mode.CSV, 100.0)
    x_jit, x_py = np.zeros(9), np.zeros(9)
    k = axis._k
    hs = 1e-4

    def run(periods: Callable[..., None], x: np.ndarray) -> None:
        for n in range(2000):  # 1 s of 0.5 ms pieces, 5 FOC steps each; 5 N m from 0.4 s
            i_q = 2.0 + 3.0 * np.sin(n / 50.0)
            loads = np.full(5, 5.0 if n >= 800 else 0.0)
            periods(x, k, i_q, True, hs, loads)

    run(im_kernel.foc_periods, x_jit)  # compiled first: numba took the compiled step in
    monkeypatch.setattr(im_kernel, "_current_loops", im_kernel._current_loops_py)
    run(im_kernel._foc_periods, x_py)
    assert abs(x_jit[4]) > 10.0  # it turned
    np.testing.assert_allclose(x_jit, x_py, rtol=1e-12, atol=1e-12)
