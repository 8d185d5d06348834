"""Fixed costs: what a command imports before it does its work (issue 26, item 6).

``rig --version`` and ``rig --help`` build the whole parser and import nothing heavy; the
configuration does not import the estimator; a run imports neither Dask (the sweep's engine)
nor the scipy submodules it does not use. Checked in a fresh interpreter, by ``sys.modules``:
the times themselves are figures of ``README`` (Fixed costs), not of a test.
"""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
HEAVY = ("numpy", "scipy", "matplotlib", "numba", "dask", "distributed", "pyarrow", "canopen", "can")


def _modules(code: str, cwd: pathlib.Path) -> set[str]:
    """The top-level packages and the modules of ``watch`` a fresh Python has after ``code``."""
    script = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=cwd, check=True)
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def _tops(modules: set[str]) -> set[str]:
    return {m.split(".")[0] for m in modules}


def test_the_parser_imports_nothing_heavy(tmp_path: pathlib.Path) -> None:
    modules = _modules("import rig.cli\nrig.cli.build_parser()", tmp_path)
    assert not _tops(modules) & set(HEAVY), sorted(_tops(modules) & set(HEAVY))
    assert "importlib.metadata" not in modules  # the version is read when --version asks for it


def test_the_configuration_does_not_import_the_estimator(tmp_path: pathlib.Path) -> None:
    modules = _modules("import rig.config", tmp_path)
    assert not {"rig.identify.estimate", "scipy.signal", "scipy.stats", "scipy.optimize"} & modules


def test_a_run_imports_neither_dask_nor_unused_scipy(tmp_path: pathlib.Path) -> None:
    config = EXAMPLES / "dc_servo_position.toml"
    code = (
        "from rig.host.recorder import Recorder\nRecorder.PLOT = False\nfrom rig.cli import main\n"
        f"assert main(['run', '--config', {str(config)!r}, '--emulate', '--duration', '0.01', '--json']) == 0"
    )
    modules = _modules(code, tmp_path)
    assert "rig.host.session" in modules  # it ran
    unused = {"scipy.signal", "scipy.stats", "scipy.optimize", "rig.identify.estimate"}
    assert not unused & modules, sorted(unused & modules)
    ours = {"dask", "distributed", "pyarrow", "numba"}
    if "asammdf" in modules:  # the export extra: python-can's can.io.mf4 imports asammdf, pandas, pyarrow
        ours.discard("pyarrow")  # with `import can` (0.4 s of its 0.5 s here), whatever the toolkit does
    assert not _tops(modules) & ours, sorted(_tops(modules))
