"""The window's import and open doors fed malformed files, through the Qt-free functions its dialogs call:
opening a project, importing control, observations and a calibration into one, adding image pairs and a
stereo video, and the readers of the control and calibration dialogs. Each spoiled file (the same
spoilings as the command line's fuzzer, tests/cli/bad_inputs.py) gives a :class:`UsvipsError` whose
message is one line naming the file, and nothing changes: not the project's tables, not the file, and no
file is left behind."""

from __future__ import annotations

import random
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.cli.bad_inputs import dump, file_spoilings, valid_inputs
from usvips.core.errors import UsvipsError


def _open(project: Path, bad: Path) -> None:
    from usvips.app.opening import open_project

    open_project(bad).close()


def _open_read_only(project: Path, bad: Path) -> None:
    from usvips.app.opening import open_project

    open_project(bad, read_only=True).close()


def _import(**files) -> Callable[[Path, Path], None]:
    def door(project: Path, bad: Path) -> None:
        from usvips.app.opening import open_project
        from usvips.app.project_contents import plan_import, store_import

        arguments = {key: (bad if value is None else value) for key, value in files.items()}
        plan = plan_import(**arguments)
        with open_project(project) as store:
            store_import(store, plan)
    return door


def _image_pairs(side: str) -> Callable[[Path, Path], None]:
    def door(project: Path, bad: Path) -> None:
        from usvips.app.opening import open_project
        from usvips.app.video_project import add_image_pairs, plan_image_pairs

        good = valid_inputs() / f"{'right' if side == 'left' else 'left'}.png"
        left, right = (bad, good) if side == "left" else (good, bad)
        plan, _ = plan_image_pairs([left], [right], "fz-")
        with open_project(project) as store:
            add_image_pairs(store, plan)
    return door


def _video(side: str) -> Callable[[Path, Path], None]:
    def door(project: Path, bad: Path) -> None:
        from usvips.app.opening import open_project
        from usvips.app.video_project import add_video

        good = valid_inputs() / f"{'right' if side == 'left' else 'left'}.mp4"
        left, right = (bad, good) if side == "left" else (good, bad)
        with open_project(project) as store:
            add_video(store, [left], [right], "fz")
    return door


def _reader(name: str) -> Callable[[Path, Path], None]:
    def door(project: Path, bad: Path) -> None:
        from usvips.io import calibration_file, tables, target_file

        {"control": tables.read_control, "observations": tables.read_observations,
         "calibration": calibration_file.load_calibration, "target": target_file.read_target}[name](bad)
    return door


def _detection_model(project: Path, bad: Path) -> None:
    from usvips.app.opening import open_project
    from usvips.gui.detect_model import DetectSession
    from usvips.gui.workspace import Workspace

    workspace = Workspace()
    with open_project(project) as store:
        workspace.open_project(store)
        DetectSession(workspace).choose_model(str(bad))


#: door → (the valid file it is given, spoiled; the function the window's dialog calls with it)
DOORS: dict[str, tuple[str, Callable[[Path, Path], None]]] = {
    "open a project": ("rov.usvips", _open),
    "open a project read-only": ("rov.usvips", _open_read_only),
    "import control": ("control.csv", _import(control=None)),
    "import observations": ("obs_air.csv", _import(observations=None, pair="fz", role="calibration-air")),
    "import a calibration": ("cal.json", _import(calibration=None, active_for=("water2",))),
    "add image pairs (left)": ("left.png", _image_pairs("left")),
    "add image pairs (right)": ("right.png", _image_pairs("right")),
    "add a video (left)": ("left.mp4", _video("left")),
    "add a video (right)": ("right.mp4", _video("right")),
    "the control dialog's reader": ("control.csv", _reader("control")),
    "the observations dialog's reader": ("obs_water.csv", _reader("observations")),
    "the calibration dialog's reader": ("cal.json", _reader("calibration")),
    "the target dialog's reader": ("target.json", _reader("target")),
    "the detection model dialog": ("fish.toml", _detection_model),
}


@dataclass(frozen=True)
class Case:
    door: str
    name: str
    label: str
    make: Callable[[Path], list[str]]


CASES = [Case(door, name, label, make) for door, (name, _) in DOORS.items()
         for label, make in file_spoilings(name, valid_inputs() / name, random.Random(f"window:{door}"))]


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    """A copy of the prepared project (with objects, pairs, a video and calibrations)."""
    folder = tmp_path_factory.mktemp("window_doors")
    shutil.copy(valid_inputs() / "rov.usvips", folder / "rov.usvips")
    return folder / "rov.usvips"


def _contents(folder: Path) -> dict[Path, bytes]:
    """The files in ``folder`` and their bytes (SQLite's own companion files left out)."""
    return {p: p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and not p.name.endswith(("-wal", "-shm", "-journal"))}


@pytest.mark.parametrize("case", CASES, ids=[f"{c.door}|{c.label}" for c in CASES])
def test_a_spoiled_file_is_a_one_line_error_and_changes_nothing(project, tmp_path, case):
    before = dump(project)
    work = tmp_path / "work"
    work.mkdir()
    bad = Path(case.make(work)[0])
    made = _contents(work)
    paths = set(work.rglob("*"))
    with pytest.raises(UsvipsError) as raised:
        DOORS[case.door][1](project, bad)
    message = str(raised.value)
    assert "\n" not in message.strip() and bad.name in message, message
    assert _contents(work) == made, "the file was changed"
    left = {p for p in set(work.rglob("*")) - paths if not p.name.endswith(("-wal", "-shm", "-journal"))}
    assert not left, f"left {sorted(map(str, left))}"
    assert dump(project) == before, "the project changed"
