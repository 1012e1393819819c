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


def test_every_package_sits_in_a_layer():
    """No module floats between layers: each subpackage of usvips is named in the layers contract (bench, the
    timing harness beside the command line, is held by the forbidden contracts instead), and the only
    top-level modules are the package's entry points and its resource finder."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    layers = next(c for c in config if c["type"] == "layers")["layers"]
    layered = {name.strip() for layer in layers for name in layer.split("|")}
    package = ROOT / "usvips"
    subpackages = {f"usvips.{p.name}" for p in package.iterdir() if (p / "__init__.py").is_file()}
    assert subpackages - {"usvips.bench"} == layered
    modules = {p.name for p in package.glob("*.py")}
    assert modules == {"__init__.py", "__main__.py", "locations.py"}


def test_app_and_the_window_take_a_project_through_the_storage_interface():
    """Where app or gui takes a project (a parameter or field annotated with a project type), the type is
    the storage interface ``ProjectStore``, never SQLite's ``Project`` (which only creating or opening names)."""
    import re

    annotated = re.compile(r"\b\w*project\w*\s*:\s*(?:\"|')?Project\b(?!Store)", re.IGNORECASE)
    offenders = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
                 for folder in ("app", "gui") for path in sorted((ROOT / "usvips" / folder).rglob("*.py"))
                 for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                 if annotated.search(line)]
    assert offenders == [], "take a usvips.store.interface.ProjectStore:\n" + "\n".join(offenders)


def test_no_module_imports_one_that_imports_it_back():
    """No import cycle between modules (an import inside a function counts: it is a cycle all the same;
    imports only for type checking do not run and do not count)."""
    import grimp

    graph = grimp.build_graph("usvips", include_external_packages=False, exclude_type_checking_imports=True)
    imports = {module: graph.find_modules_directly_imported_by(module) for module in graph.modules}
    cycles = sorted({tuple(sorted((a, b))) for a, targets in imports.items() for b in targets
                     if graph.chain_exists(importer=b, imported=a)})
    assert cycles == [], f"modules in an import cycle with each other: {cycles}"
