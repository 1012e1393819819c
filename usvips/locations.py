"""Where the data that ships with USVIPS lives: the sample projects and the resources.

Both stay at the top of the source tree (``sample_projects/``, ``resources/``); the package reaches them
through the links ``usvips/sample_projects`` and ``usvips/resources``, which a built package carries as
package data. They are found with :mod:`importlib.resources`, so an installed USVIPS (not only an
editable checkout) finds them.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def _packaged(name: str) -> Path:
    return Path(str(resources.files("usvips") / name))


def sample_projects() -> Path:
    """The folder holding the bundled sample projects (one folder each, with its ``project.json``)."""
    return _packaged("sample_projects")


def sample_project(name: str) -> Path:
    """One bundled sample project's folder, e.g. ``sample_project("tank_1995")``."""
    return sample_projects() / name


def resources_folder() -> Path:
    """The folder of shared resources (e.g. ``calibration_frame.csv``, the thesis's frame)."""
    return _packaged("resources")
