"""Property-based bad input: valid files of every format, mutated, fed to the command line.

The contract for every mutation: the command either succeeds (the mutation kept the file valid) or exits
with status 2 and exactly one line on stderr that names the file at fault; never a traceback, never an
internal error, no partial output (no file or folder left behind), and nothing committed in a project
changed. Formats: control CSV, observation (picks) CSV, calibration JSON, scene JSON, sample manifest and
the project file's own bytes.

Examples are derandomised (the same every run, so CI replays exactly what failed) and few per format, so
the suite runs in tens of seconds.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import shutil
import sqlite3
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from usvips.cli import main
from usvips.store import Project

ROOT = Path(__file__).resolve().parents[2]
TANK = ROOT / "sample_projects" / "tank_1995"
ROV = ROOT / "sample_projects" / "rov_flatport"

REPLAY = settings(derandomize=True, deadline=None, max_examples=80, database=None,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

#: Pieces a careless user or a hostile file puts into a text file.
TOKENS = ["", ",", ",,", "\n", "\r\n", "\x00", '"', "'", "nan", "inf", "-1", "0", "1e999", "-0", "1,2",
          "999999999999999999999", "\ufeff", "é", "#", "x" * 300, "\t", "{", "}", "[", "]", ":", "null",
          "true", "../", "/etc/passwd", "\\", "\xff", "\u202e"]

#: Values a JSON mutation puts in place of another.
VALUES = [None, True, False, 0, -1, 1, 0.5, -1e-9, 1e308, -1e308, 2**64, "", "64", "x" * 500, [], {}, [1, 2],
          [[[[[[[[[[1]]]]]]]]]], {"a": 1}, "../../escape", "nan"]


def run(args: list[str]) -> tuple[int, str]:
    """``usvips ARGS`` in this process: (exit status, stderr). stdout is discarded."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(args)
    return code, err.getvalue()


def assert_contract(code: int, err: str, culprits: tuple[str, ...]) -> None:
    """Success, or status 2 with one line on stderr naming one of ``culprits``."""
    assert code in (0, 2), f"exit {code}: {err}"
    if code == 2:
        assert err.endswith("\n") and err.count("\n") == 1, f"not one line: {err!r}"
        assert "Traceback" not in err and "internal error" not in err, err
        assert any(c in err for c in culprits), f"names none of {culprits}: {err}"


def dump(project: Path) -> list[str]:
    """Everything committed in a project, read without writing."""
    connection = sqlite3.connect(f"file:{project}?mode=ro", uri=True)
    try:
        return list(connection.iterdump())
    finally:
        connection.close()


@st.composite
def text_mutation(draw, text: str) -> str:
    """``text`` with one to three edits: a span replaced by a token, a line dropped or doubled, cut short."""
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["replace", "replace", "drop", "double", "truncate"]))
        lines = text.splitlines(keepends=True) or [""]
        if kind == "replace" and text:
            start = draw(st.integers(0, len(text) - 1))
            end = draw(st.integers(start, min(len(text), start + 12)))
            text = text[:start] + draw(st.sampled_from(TOKENS)) + text[end:]
        elif kind == "drop":
            del lines[draw(st.integers(0, len(lines) - 1))]
            text = "".join(lines)
        elif kind == "double":
            i = draw(st.integers(0, len(lines) - 1))
            text = "".join(lines[:i + 1] + lines[i:])
        else:
            text = text[:draw(st.integers(0, len(text)))]
    return text


def _paths(data, prefix=()):
    """Every (path, value) inside a JSON value."""
    yield prefix, data
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _paths(value, (*prefix, key))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            yield from _paths(value, (*prefix, i))


@st.composite
def json_mutation(draw, data: dict) -> str:
    """``data`` with one to three values replaced or keys removed, or (sometimes) its text mutated."""
    data = json.loads(json.dumps(data))
    if draw(st.integers(0, 4)) == 0:
        return draw(text_mutation(json.dumps(data, indent=1)))
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p, _ in _paths(data) if p]
        path = draw(st.sampled_from(paths))
        parent = data
        for key in path[:-1]:
            parent = parent[key]
        if isinstance(parent, dict) and draw(st.booleans()):
            del parent[path[-1]]
        else:
            parent[path[-1]] = copy.deepcopy(draw(st.sampled_from(VALUES)))
    return json.dumps(data)


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> dict[str, Path]:
    """A project made from the thesis-tank sample, and the valid files the mutations start from."""
    folder = tmp_path_factory.mktemp("base")
    project = folder / "tank.usvips"
    assert run(["project", "new", str(project), "--from", str(TANK)])[0] == 0
    scene = json.loads((ROV / "scene.json").read_text())
    for key in ("frame", "video", "description"):
        scene.pop(key)
    scene["image"] = {"width": 64, "height": 48, "supersample": 1}    # the rig scaled to a tenth
    for side in ("left", "right"):
        scene[side].update({k: scene[side][k] / 10 for k in ("f", "xp", "yp")})
    scene["pairs"] = [p for p in scene["pairs"] if p["label"] == "measure1"]
    (folder / "scene.json").write_text(json.dumps(scene))
    assert run(["render", str(folder / "scene.json"), "--out", str(folder / "rendered")])[0] == 0
    return {"folder": folder, "project": project, "scene": folder / "scene.json"}


def _import_case(base, name: str, text: str, option: list[str]) -> None:
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        project = work / "p.usvips"
        shutil.copy(base["project"], project)
        before = dump(project)
        path = work / name
        path.write_bytes(text.encode("utf-8", "surrogatepass"))
        code, err = run(["project", "import", str(project), *option[:1], str(path), *option[1:]])
        assert_contract(code, err, (name, "p.usvips: pair"))   # the file, or a clash with what is stored
        if code == 2:
            assert dump(project) == before, "a failed import changed the project"
        assert _files(work) == sorted(["p.usvips", name])


def _files(folder: Path) -> list[str]:
    """The files in ``folder``, without SQLite's own -wal/-shm companions of a project."""
    return sorted(p.name for p in folder.iterdir() if not p.name.endswith(("-wal", "-shm")))


@REPLAY
@given(data=st.data())
def test_mutated_control_files(base, data):
    text = data.draw(text_mutation((TANK / "control_table3_2.csv").read_text()))
    _import_case(base, "control.csv", text, ["--control"])


@REPLAY
@given(data=st.data())
def test_mutated_picks_files(base, data):
    text = data.draw(text_mutation((ROV / "observations_water.csv").read_text()[:3000]))
    _import_case(base, "picks.csv", text, ["--obs", "--pair", "water2", "--role", "measurement"])


def _measure_picks() -> str:
    """A valid picks file: the ROV sample's fish, snout to fork, at their true pixels."""
    truth = json.loads((ROV / "truth.json").read_text())
    cameras = next(p for p in truth["pairs"] if p["label"] == "measure1")["cameras"]
    rows = ["object,type,vertex,xl,yl,xr,yr,attribute"]
    for number, fish in enumerate(("fish1", "fish2"), start=1):
        for vertex, point in enumerate(("snout", "fork")):
            left, right = cameras["left"]["objects"][fish][point], cameras["right"]["objects"][fish][point]
            rows.append(f"{fish},line,{vertex},{left[0]:.3f},{left[1]:.3f},{right[0]:.3f},{right[1]:.3f},fish{number}")
    return "\n".join(rows) + "\n"


@REPLAY
@given(data=st.data())
def test_mutated_measurement_picks(data):
    text = data.draw(text_mutation(_measure_picks()))
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / "picks.csv").write_text(text, encoding="utf-8", errors="surrogatepass")
        code, err = run(["measure", "--calibration", str(ROV / "calibration.json"), "--picks",
                         str(work / "picks.csv"), "--out", str(work / "objects.csv")])
        assert_contract(code, err, ("picks.csv", "object"))
        if code == 2:
            assert _files(work) == ["picks.csv"], "a failed measure left files"


@REPLAY
@given(data=st.data())
def test_mutated_calibration_files(base, data):
    text = data.draw(json_mutation(json.loads((ROV / "calibration.json").read_text())))
    _import_case(base, "calibration.json", text, ["--calibration", "--active-for", "water2"])


@REPLAY
@given(data=st.data())
def test_mutated_scenes(base, data):
    text = data.draw(json_mutation(json.loads(base["scene"].read_text())))
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        scene = work / "scene.json"
        scene.write_text(text)
        code, err = run(["render", str(scene), "--out", str(work / "out")])
        assert_contract(code, err, ("scene.json",))
        if code == 2:
            assert sorted(p.name for p in work.iterdir()) == ["scene.json"], "a failed render left files"


@REPLAY
@given(data=st.data())
def test_mutated_manifests(base, data):
    text = data.draw(json_mutation(json.loads((TANK / "project.json").read_text())))
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        sample = work / "tank"
        shutil.copytree(TANK, sample, ignore=shutil.ignore_patterns("project.usvips*"))
        (sample / "project.json").write_text(text)
        code, err = run(["project", "new", str(work / "new.usvips"), "--from", str(sample)])
        assert_contract(code, err, (str(sample),))
        if code == 2:
            assert sorted(p.name for p in work.iterdir()) == ["tank"], "a failed 'project new' left files"


@REPLAY
@given(data=st.data())
def test_mutated_project_files(base, data):
    """Damaged bytes of a project: 'project info' reads it or says in one line what is wrong, and (a
    read-only command) never changes a byte."""
    original = base["project"].read_bytes()
    damaged = bytearray(original)
    for _ in range(data.draw(st.integers(1, 4))):
        kind = data.draw(st.sampled_from(["bytes", "bytes", "truncate", "page"]))
        if kind == "bytes" and damaged:
            at = data.draw(st.integers(0, len(damaged) - 1))
            damaged[at:at + 8] = data.draw(st.binary(min_size=1, max_size=8))
        elif kind == "truncate":
            damaged = damaged[:data.draw(st.integers(0, len(damaged)))]
        elif len(damaged) >= 4096:
            page = data.draw(st.integers(0, len(damaged) // 4096 - 1))
            damaged[page * 4096:(page + 1) * 4096] = bytes(4096)
    with tempfile.TemporaryDirectory() as work:
        project = Path(work) / "p.usvips"
        project.write_bytes(bytes(damaged))
        for command in (["project", "info", str(project)],
                        ["project", "export", str(project), str(Path(work) / "objects.csv")]):
            code, err = run(command)
            assert_contract(code, err, ("p.usvips",))
            assert project.read_bytes() == bytes(damaged), f"{command[1]} changed the project"


def _opencv_stereo_file(folder: Path) -> str:
    """A valid OpenCV stereo calibration file (YAML, as cv2.FileStorage writes it)."""
    import cv2
    import numpy as np

    path = folder / "stereo.yml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for name, value in dict(M1=np.array([[810.0, 0, 641.5], [0, 798.0, 478.25], [0, 0, 1]]),
                            D1=np.array([[-0.12, 0.03, 1e-3, 0, 0.01]]),
                            M2=np.array([[805.0, 0, 630.0], [0, 801.0, 482.0], [0, 0, 1]]),
                            D2=np.array([[-0.10, 0.02, 0, 1e-3]]), R=np.eye(3),
                            T=np.array([[-0.39], [0.006], [0.012]])).items():
        storage.write(name, value)
    storage.write("image_width", 1280)
    storage.write("image_height", 960)
    storage.release()
    return path.read_text()


@REPLAY
@given(data=st.data())
def test_mutated_opencv_calibrations(tmp_path_factory, data):
    """A damaged OpenCV file (a line dropped, a number replaced, cut short) never reaches OpenCV's reader in a
    form that ends the process or raises its own assertion."""
    text = data.draw(text_mutation(_opencv_stereo_file(tmp_path_factory.mktemp("opencv"))))
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / "stereo.yml").write_text(text, encoding="utf-8", errors="surrogatepass")
        code, err = run(["calibration", "import", str(work / "stereo.yml"), "--out", str(work / "c.json")])
        assert_contract(code, err, ("stereo.yml",))
        if code == 2:
            assert _files(work) == ["stereo.yml"], "a failed import left files"


def test_an_overflowing_value_is_still_one_line(tmp_path):
    """numpy's overflow warnings on an absurd value do not print above the error line."""
    data = json.loads((ROV / "calibration.json").read_text())
    data["cameras"]["right"]["interior"]["k2"] = 1e300
    data["parameters"]["k2_r"]["value"] = 1e300  # both, or the file is refused for their disagreement
    (tmp_path / "c.json").write_text(json.dumps(data))
    (tmp_path / "picks.csv").write_text(_measure_picks())
    code, err = run(["measure", "--calibration", str(tmp_path / "c.json"), "--picks", str(tmp_path / "picks.csv"),
                     "--out", str(tmp_path / "objects.csv")])
    assert code == 2 and err.count("\n") == 1 and "k2=1e+300" in err, err


# ---------------------------------------------------------------------------- never overwrite a source
def _spellings(path: Path, draw) -> Path:
    """Another name for ``path``: itself, through ``sub/..``, a symbolic link or a hard link."""
    how = draw(st.sampled_from(["same", "dotdot", "symlink", "hardlink"]))
    if how == "dotdot":
        (path.parent / "sub").mkdir(exist_ok=True)
        return path.parent / "sub" / ".." / path.name
    if how in ("symlink", "hardlink"):
        alias = path.with_name(f"alias_{path.name}")
        (alias.symlink_to if how == "symlink" else alias.hardlink_to)(path)
        return alias
    return path


@pytest.fixture(scope="module")
def sources(base, tmp_path_factory) -> dict[str, Path]:
    """Inputs of the writing commands: a calibration, picks for it, an OpenCV file, a project with objects."""
    folder = tmp_path_factory.mktemp("sources")
    (folder / "stereo.yml").write_text(_opencv_stereo_file(folder))
    shutil.copy(ROV / "calibration.json", folder / "cal.json")
    (folder / "picks.csv").write_text(_measure_picks())
    obs = (ROV / "observations_water.csv").read_text().splitlines()
    (folder / "obs.csv").write_text("\n".join(obs[:6]) + "\n")
    shutil.copy(base["project"], folder / "p.usvips")
    return {"folder": folder}


#: command templates: {name: (argv with {out} and the inputs named as files in the folder, inputs)}
WRITERS = {
    "calibration export": (["calibration", "export", "cal.json", "--out", "{out}"], ["cal.json"]),
    "calibration import": (["calibration", "import", "stereo.yml", "--out", "{out}"], ["stereo.yml"]),
    "intersect": (["intersect", "--calibration", "cal.json", "--obs", "obs.csv", "--out", "{out}"],
                  ["cal.json", "obs.csv"]),
    "measure": (["measure", "--calibration", "cal.json", "--picks", "picks.csv", "--out", "{out}"],
                ["cal.json", "picks.csv"]),
    "project export": (["project", "export", "p.usvips", "{out}"], ["p.usvips"]),
}


@settings(derandomize=True, deadline=None, max_examples=60, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_no_command_overwrites_its_input_a_project_or_a_calibration(sources, data):
    """Each writing command pointed at one of its own inputs (by any name of it), at a project or at a
    calibration: refused in one line with every file untouched — or, with --force, replaced and the old
    bytes kept as NAME.bak; the project a command works on is never replaced."""
    name = data.draw(st.sampled_from(sorted(WRITERS)))
    template, inputs = WRITERS[name]
    victim = data.draw(st.sampled_from([*inputs, "p.usvips", "cal.json"]))
    force = data.draw(st.booleans())
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        for file in sources["folder"].iterdir():
            if file.is_file():
                shutil.copy(file, work / file.name)
        before = {p.name: p.read_bytes() for p in work.iterdir()}
        out = _spellings(work / victim, data.draw)
        argv = [str(out) if a == "{out}" else str(work / a) if (work / a).exists() else a for a in template]
        code, err = run(argv + (["--force"] if force else []))
        never = name == "project export" and victim == "p.usvips"
        after = {p.name: p.read_bytes() for p in work.iterdir() if p.is_file() and not p.name.endswith(
            ("-wal", "-shm")) and not (p.name.startswith("alias_") and not p.name.endswith(".bak"))}
        if not force or never:
            assert code == 2 and err.count("\n") == 1, (argv, err)
            assert (victim in err or out.name in err) and "destroy" in err, err
            assert after == before, f"{name} changed a file it refused to write"
        elif code == 2:  # replacing allowed, but the file cannot take this output (e.g. its extension)
            assert err.count("\n") == 1 and "Traceback" not in err, err
            assert after == before, f"{name} changed a file on an error"
        else:
            assert code == 0, (argv, err)
            assert after[f"{out.name}.bak"] == before[victim], "the old file was not kept"
            assert after.keys() - before.keys() == {f"{out.name}.bak"}, "files besides the backup appeared"


# ---------------------------------------------------------------------------- damaged containers
def _npz_bytes(folder: Path, **extra) -> bytes:
    """A valid NumPy .npz stereo calibration (OpenCV's names), compressed or not."""
    import numpy as np

    arrays = dict(M1=np.array([[810.0, 0, 641.5], [0, 798.0, 478.25], [0, 0, 1]]),
                  D1=np.array([[-0.12, 0.03, 0, 0, 0]]), M2=np.array([[805.0, 0, 630.0], [0, 801.0, 482.0], [0, 0, 1]]),
                  D2=np.zeros((1, 5)), R=np.eye(3), T=np.array([[-0.39], [0.006], [0.012]]),
                  image_size=np.array([1280, 960]))
    arrays.update(extra)
    path = folder / "stereo.npz"
    np.savez_compressed(path, **arrays)
    return path.read_bytes()


@st.composite
def byte_damage(draw, data: bytes) -> bytes:
    """``data`` with one to four damages: bytes changed, a span cut out or cut short, garbage inserted."""
    data = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["flip", "flip", "cut", "truncate", "insert"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "flip" and data:
            data[at] ^= draw(st.integers(1, 255))
        elif kind == "cut":
            del data[at:at + draw(st.integers(1, 200))]
        elif kind == "truncate":
            del data[at:]
        else:
            data[at:at] = draw(st.binary(min_size=1, max_size=64))
    return bytes(data)


@REPLAY
@given(data=st.data())
def test_damaged_npz_calibrations_are_one_line(tmp_path_factory, data):
    import numpy as np

    folder = tmp_path_factory.mktemp("npz")
    odd = data.draw(st.sampled_from([{}, {"R": np.array(["a", "b"])}, {"T": np.zeros((0,))},
                                     {"M1": np.full((3, 3), np.nan)}, {"D1": np.zeros((2000, 2000), np.float32)},
                                     {"R": np.array([1 + 2j] * 9).reshape(3, 3)}]))
    damaged = data.draw(byte_damage(_npz_bytes(folder, **odd))) if data.draw(st.booleans()) else _npz_bytes(
        folder, **odd)
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / "stereo.npz").write_bytes(damaged)
        code, err = run(["calibration", "import", str(work / "stereo.npz"), "--out", str(work / "c.json")])
        assert_contract(code, err, ("stereo.npz",))
        if code == 2:
            assert _files(work) == ["stereo.npz"], "a failed import left files"


@REPLAY
@given(data=st.data())
def test_damaged_opencv_xml_and_yaml_bytes_are_one_line(tmp_path_factory, data):
    """Byte-level damage (not only text edits) to OpenCV files of both syntaxes."""
    import cv2

    folder = tmp_path_factory.mktemp("xml")
    suffix = data.draw(st.sampled_from([".yml", ".xml"]))
    text = _opencv_stereo_file(folder)
    source = cv2.FileStorage(str(folder / "stereo.yml"), cv2.FILE_STORAGE_READ)
    storage = cv2.FileStorage(str(folder / f"s{suffix}"), cv2.FILE_STORAGE_WRITE)
    for key in ("M1", "D1", "M2", "D2", "R", "T"):
        storage.write(key, source.getNode(key).mat())
    storage.release()
    source.release()
    damaged = data.draw(byte_damage((folder / f"s{suffix}").read_bytes() if suffix == ".xml" else text.encode()))
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / f"stereo{suffix}").write_bytes(damaged)
        code, err = run(["calibration", "import", str(work / f"stereo{suffix}"), "--image-size", "1280x960",
                         "--out", str(work / "c.json")])
        assert_contract(code, err, (f"stereo{suffix}",))
        if code == 2:
            assert _files(work) == [f"stereo{suffix}"], "a failed import left files"


# ---------------------------------------------------------------------------- validation at the new doors
#: per option of `usvips plan` (a rig on paper), values it must refuse by name
BAD_PLAN_VALUES = {
    "--height": ["nan", "inf", "-inf", "1e999"],
    "--length": ["nan", "0", "-0.3", "inf"],
    "--baseline": ["nan", "0", "-1", "inf"],
    "--focal-px": ["nan", "0", "-800", "inf"],
    "--sigma-px": ["nan", "0", "-0.3"],
    "--toe-in": ["nan", "90", "-95", "inf"],
    "--orientations": ["0", "-3", "100000000", "1e8", "2.5", "nan", "x"],
    "--range": ["1:2:100000000", "1:2:0", "1:2:-4", "1:2:1e9", "nan:2", "1:inf", "1:2:x"],
    "--across": ["-1:1:100000000", "-1:1:0", "-1:nan"],
    "--image-size": ["99999999x480", "640x100000", "0x0", "nanxnan", "640", "-640x480"],
}


@settings(derandomize=True, deadline=None, max_examples=60, database=None)
@given(data=st.data())
def test_plan_numbers_and_counts_are_named_not_blamed_on_memory(data):
    """Any option of the planner given a non-finite, out-of-range or absurd value (a count of 10⁸): one line
    naming that option — never "not enough memory", "points" or a range it did not give."""
    option = data.draw(st.sampled_from(sorted(BAD_PLAN_VALUES)))
    value = data.draw(st.sampled_from(BAD_PLAN_VALUES[option]))
    argv = ["plan", "--focal-px", "800", "--image-size", "640x480", "--baseline", "0.3", "--range", "1:3:3",
            "--across=-0.5:0.5:3", "--orientations", "4", "--json"]
    argv = [a for a in argv if not a.startswith(f"{option}=")]
    if option in argv:
        del argv[argv.index(option):argv.index(option) + 2]
    argv.append(f"{option}={value}")  # the = form: a value may begin with "-"
    code, err = run(argv)
    assert code == 2 and err.count("\n") == 1 and option in err, (option, value, err)
    assert "memory" not in err and "Traceback" not in err


def _control_text(draw) -> str:
    """A name with a control or invisible formatting character somewhere."""
    bad = draw(st.sampled_from(["\x00", "\x01", "\x07", "\x1b", "\t", "\n", "\r", "\x7f", "\x85", "\u200b",
                                "\u202e", "\u2028", "\ufeff"]))
    name = draw(st.text(alphabet="abcXYZ012-_ .é", min_size=0, max_size=12))
    at = draw(st.integers(0, len(name)))
    return name[:at] + bad + name[at:]


@pytest.fixture(scope="module")
def video_project(tmp_path_factory) -> dict[str, Path]:
    """A project holding the ROV sample's stereo video (label "video") and its files."""
    folder = tmp_path_factory.mktemp("video_project")
    project = folder / "rov.usvips"
    assert run(["project", "new", str(project), "--from", str(ROV)])[0] == 0
    return {"project": project, "left": ROV / "video_left.avi", "right": ROV / "video_right.avi"}


@settings(derandomize=True, deadline=None, max_examples=40, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_names_with_control_characters_are_refused_and_nothing_stored(video_project, data):
    name = _control_text(data.draw)
    project = video_project["project"]
    command, option = data.draw(st.sampled_from([
        (["project", "add-video", str(project), "--left", str(video_project["left"]), "--right",
          str(video_project["right"]), f"--label={name}"], "--label"),
        (["video", "period", str(project), "--pair", "video", "--add", "x" + name, "1", "3"], "--add NAME"),
        (["video", "take-pair", str(project), "--pair", "video", "--frame", "5", f"--label={name}"], "--label"),
        (["project", "add-pairs", str(project), "--left", str(ROV / "images" / "measure1_left.png"), "--right",
          str(ROV / "images" / "measure1_right.png"), f"--label-prefix={name}", "--pair-by", "order"],
         "--label-prefix"),
        (["project", "set-metadata", str(project), "--opcode", "OP1", f"--site={name}"], "--site"),
        (["project", "set-metadata", str(project), f"--opcode={name}"], "--opcode"),
    ]))
    before = dump(project)
    code, err = run(command)
    assert code == 2 and err.count("\n") == 1 and option in err and "control character" in err, (name, err)
    assert dump(project) == before


@settings(derandomize=True, deadline=None, max_examples=30, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_file_given_twice_is_refused_as_both_cameras_or_as_two_chapters(video_project, tmp_path_factory, data):
    """The same recording — by its name, another spelling of it or a link — twice in one camera's list
    or once for each camera: one line naming it, nothing stored; one image in two pairs likewise."""
    folder = tmp_path_factory.mktemp("twice")
    left, right = video_project["left"], video_project["right"]
    how = data.draw(st.sampled_from(["same", "dotdot", "symlink"]))
    alias = {"same": left, "dotdot": left.parent / ".." / left.parent.name / left.name,
             "symlink": folder / "alias.avi"}[how]
    if how == "symlink":
        alias.symlink_to(left)
    lefts, rights = [left], [right]
    if data.draw(st.booleans()):
        rights = [alias]  # the same video as both cameras
    else:
        lefts.insert(data.draw(st.integers(0, 1)), alias)  # the same chapter twice
        rights = [right, right] if data.draw(st.booleans()) else [right]
    project = video_project["project"]
    before = dump(project)
    code, err = run(["project", "add-video", str(project), "--left", *map(str, lefts), "--right", *map(str, rights),
                     "--label", "twice"])
    assert code == 2 and err.count("\n") == 1 and "the same file" in err, err
    assert dump(project) == before
    image = ROV / "images" / "measure1_left.png"
    other = ROV / "images" / "measure1_right.png"
    code, err = run(["project", "add-pairs", str(project), "--left", str(image), str(other), "--right", str(other),
                     str(image), "--pair-by", "order", "--dry-run"])
    assert code == 2 and "the same file" in err and err.count("\n") == 1, err
    code, err = run(["project", "add-pairs", str(project), "--left", str(ROV / "images" / "measure1_left.png"),
                     "--right", str(ROV / "images" / "air1_right.png"), "--pair-by", "order"])
    assert code == 2 and "already an image of pair" in err, err  # measure1_left.png is in the sample's pairs


@REPLAY
@given(data=st.data())
def test_picks_with_a_vertex_given_twice_are_refused_by_line(data):
    lines = _measure_picks().splitlines()
    k = data.draw(st.integers(1, len(lines) - 1))
    twice = lines[:k + 1] + [lines[k]] + lines[k + 1:]  # a vertex line repeated …
    if data.draw(st.booleans()):  # … or another vertex renumbered onto it
        fields = lines[k].split(",")
        others = [i for i in range(1, len(lines)) if i != k and lines[i].split(",")[0] == fields[0]]
        i = data.draw(st.sampled_from(others))
        moved = lines[i].split(",")
        moved[2] = fields[2]
        twice = list(lines)
        twice[i] = ",".join(moved)
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / "picks.csv").write_text("\n".join(twice) + "\n")
        code, err = run(["measure", "--calibration", str(ROV / "calibration.json"), "--picks",
                         str(work / "picks.csv"), "--out", str(work / "objects.csv")])
        assert code == 2 and "is given twice" in err and "picks.csv, line" in err and err.count("\n") == 1, err
        assert _files(work) == ["picks.csv"]


@REPLAY
@given(data=st.data())
def test_a_pixel_outside_the_image_is_named_as_such(data):
    lines = _measure_picks().splitlines()
    k = data.draw(st.integers(1, len(lines) - 1))
    fields = lines[k].split(",")
    column = data.draw(st.integers(3, 6))
    limit = 640 if column in (3, 5) else 480  # the ROV sample's images are 640 × 480 px
    fields[column] = str(data.draw(st.one_of(st.floats(-1e7, -0.51), st.floats(limit - 0.49, 1e7))))
    lines[k] = ",".join(fields)
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / "picks.csv").write_text("\n".join(lines) + "\n")
        code, err = run(["measure", "--calibration", str(ROV / "calibration.json"), "--picks",
                         str(work / "picks.csv"), "--out", str(work / "objects.csv")])
        assert code == 2 and "lies outside the" in err and f"line {k + 1}" in err, err
        assert "cannot be inverted" not in err


@REPLAY
@given(data=st.data())
def test_provenance_paths_are_shown_never_read_outside_the_calibration_folder(tmp_path_factory, data):
    """A calibration naming its control and observations as paths that leave its folder (``..`` steps,
    absolute paths, a link out): the report lists them unread; a secret outside is never opened."""
    from usvips.io.calibration_file import load_calibration
    from usvips.io.calibration_report import find_data

    root = tmp_path_factory.mktemp("provenance")
    secret = root / "secret.csv"
    secret.write_text((TANK / "control_table3_2.csv").read_text())  # a readable control file, outside
    folder = root / "a" / "b"
    folder.mkdir(parents=True)
    how = data.draw(st.sampled_from(["dotdot", "absolute", "link", "deep"]))
    recorded = {"dotdot": "../../secret.csv", "absolute": str(secret), "link": "inside.csv",
                "deep": "x/../../../" + "../" * data.draw(st.integers(0, 3)) + "secret.csv"}[how]
    if how == "link":
        (folder / "inside.csv").symlink_to(secret)
    calibration = json.loads((ROV / "calibration.json").read_text())
    calibration["source"] = {"control": recorded, "observations": recorded}
    (folder / "cal.json").write_text(json.dumps(calibration))
    found = find_data(load_calibration(folder / "cal.json"), folder / "cal.json")
    assert found.control is None and found.observations is None
    assert all("not read" in why or "not found" in why for _, _, why in found.files), found.files


def test_a_header_only_species_list_is_refused(tmp_path):
    from usvips.core.errors import InputFileError
    from usvips.io.species_list import read_species_list

    rng = __import__("numpy").random.default_rng(4)
    for n in range(20):
        blank = ["", "   ", "# a comment", "#"]
        lines = [str(rng.choice(blank)) for _ in range(int(rng.integers(0, 4)))] + ["family,genus,species,code"]
        lines += [str(rng.choice(blank)) for _ in range(int(rng.integers(0, 4)))]
        path = tmp_path / f"list{n}.csv"
        path.write_text("\n".join(lines) + ("\n" if rng.random() < 0.5 else ""))
        with pytest.raises(InputFileError, match="lists no species"):
            read_species_list(path)


@pytest.fixture(scope="module")
def matroska(tmp_path_factory) -> dict[str, Path]:
    """A 60-frame Matroska stereo video (25 fps) to damage."""
    from usvips.core.synth.frame_numbers import numbered_frame
    from usvips.io.video_writer import encode_video

    folder = tmp_path_factory.mktemp("mkv")
    for side, offset in (("left", 0), ("right", 1000)):
        encode_video(folder / f"{side}.mkv", [numbered_frame(offset + i, 160, 120, seed=1) for i in range(60)], 25,
                     "h264", gop=20)
    return {"left": folder / "left.mkv", "right": folder / "right.mkv"}


@settings(derandomize=True, deadline=None, max_examples=40, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_cut_short_or_damaged_matroska_video_is_one_line_never_fewer_frames_unsaid(matroska, data):
    from usvips.io.video_stream import CUT_SHORT_FRAMES

    whole = matroska["left"].read_bytes()
    if data.draw(st.booleans()):
        damaged = whole[: int(len(whole) * data.draw(st.floats(0.02, 0.97)))]  # an unfinished copy
    else:
        damaged = data.draw(byte_damage(whole))
    scan = data.draw(st.booleans())  # every frame decoded, a damaged packet an error
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        (work / "cut.mkv").write_bytes(damaged)
        Project.create(work / "p.usvips").close()
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = main(["project", "add-video", str(work / "p.usvips"), "--left", str(work / "cut.mkv"), "--right",
                         str(matroska["right"]), "--label", "v", *(["--scan"] if scan else [])])
        assert_contract(code, err.getvalue(), ("cut.mkv", "right.mkv"))
        if code == 0:  # accepted whole, short by less than the cut-short tolerance, or its gap or shortness said
            with Project.open(work / "p.usvips", read_only=True) as project:
                count = project.video("v").frame_count
            said = "dropped frame" in out.getvalue() or "frame counts differ" in out.getvalue()
            assert count >= 60 - CUT_SHORT_FRAMES or said, (count, out.getvalue())


def test_contradictory_options_are_refused_as_their_siblings_refuse_them(video_project):
    """Options that cannot both hold, refused in one line naming them, nothing stored."""
    project = str(video_project["project"])
    before = dump(video_project["project"])
    for argv, named in [
        (["video", "sync", project, "--pair", "video", "--dry-run", "--force"], "--dry-run"),
        (["video", "sync", project, "--pair", "video", "--method", "flash", "--calibration", "1"], "--calibration"),
        (["project", "set-georeference", project, "--clear", "--latitude", "10"], "--latitude"),
        (["project", "set-georeference", project, "--clear", "--points", "geo.csv"], "--points"),
        (["project", "set-metadata", project, "--clear", "--site", "x"], "--clear"),
        (["batch", "intersect", "--calibration", "c.json", "--out-dir", "o", "--jobs", "100000000", "a.csv"],
         "--jobs"),
    ]:
        code, err = run(argv)
        assert code == 2 and err.count("\n") == 1 and named in err, (argv, err)
    assert dump(video_project["project"]) == before


def test_a_rendering_never_replaces_a_calibration_unasked(base, tmp_path):
    """Rendering into a folder where a file it writes holds a calibration (here someone's calibration saved
    as truth.json): refused before anything is moved in; with --force kept as NAME.bak."""
    out = tmp_path / "again"
    shutil.copytree(base["folder"] / "rendered", out)
    shutil.copy(ROV / "calibration.json", out / "truth.json")
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    code, err = run(["render", str(base["scene"]), "--out", str(out)])
    assert code == 2 and err.count("\n") == 1 and "USVIPS calibration" in err and "--force" in err, err
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "a staging folder was left"
    assert run(["render", str(base["scene"]), "--out", str(out), "--force"])[0] == 0
    kept = sorted(p.name for p in out.glob("*.bak"))
    assert kept and all(before[Path(name[:-4])] == (out / name).read_bytes() for name in kept)
