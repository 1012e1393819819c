"""The layering rules of ARCHITECTURE.md, checked by tools rather than by hope."""

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_core_loads_no_qt_module_in_a_fresh_interpreter():
    code = ("import sys, usvips.core.camera, usvips.core.intersection, usvips.core.calibration, usvips.core.dlt;"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in {'PySide6', 'shiboken6', 'pyqtgraph'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out.strip() == "[]"


def test_import_contracts_hold():
    linter = shutil.which("lint-imports")
    assert linter, "import-linter is part of the test extra"
    result = subprocess.run([linter], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stdout[-2000:]


def test_the_code_is_ruff_clean():
    result = subprocess.run([sys.executable, "-m", "ruff", "check", "usvips", "tests"], capture_output=True,
                            text=True, cwd=ROOT)
    assert result.returncode == 0, result.stdout[-3000:]
