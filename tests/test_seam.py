"""The storage seam holds in the code: outside the store, projects are opened and created by location
(store/opening.py), never by naming the SQLite class; a stored calibration is read, stored and made
active through the calibration service (app/calibrations.py), never converted from its dict in place."""

import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "usvips"


def _sources(skip: tuple[str, ...]):
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE).as_posix()
        if not relative.startswith(skip):
            yield relative, path.read_text(encoding="utf-8")


def test_no_code_outside_the_store_opens_or_creates_a_project_by_its_class():
    found = [f"{name}: {m.group(0)}" for name, text in _sources(("store/",))
             for m in re.finditer(r"\b(Server)?Project\.(open|create)\(", text)]
    assert found == []


def test_stored_calibrations_go_through_the_calibration_service():
    patterns = (r"calibration_from_dict\([^)]*\.calibration\(", r"\.add_calibration\(", r"\.activate_calibration\(")
    found = [f"{name}: {m.group(0)}" for name, text in _sources(("store/", "app/calibrations.py"))
             for pattern in patterns for m in re.finditer(pattern, text)]
    assert found == []
