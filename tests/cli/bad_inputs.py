"""Malformed inputs shared by the bad-input fuzzers of the command line (tests/cli/test_bad_input_doors.py)
and of the window's Qt-free doors (tests/app/test_bad_input_window_doors.py): the valid inputs they start
from, and every way a file of each kind, or a server address, is spoiled (seeded: the same every run)."""

from __future__ import annotations

import atexit
import contextlib
import functools
import io
import json
import random
import shutil
import sqlite3
import tempfile
from collections.abc import Callable
from pathlib import Path

from usvips.cli import main

ROOT = Path(__file__).resolve().parents[2]
ROV = ROOT / "sample_projects" / "rov_flatport"
TANK = ROOT / "sample_projects" / "tank_1995"

#: passwords in the server addresses below: none of them may ever be printed
PASSWORDS = ("s3cr#t@word", "pa%ZZword", "hunter22pw", "tr0ub4dor&3")



def _picks() -> str:
    """A valid picks file: the ROV sample's two fish, snout to fork, at their true pixels in pair measure1."""
    truth = json.loads((ROV / "truth.json").read_text())
    cameras = next(p for p in truth["pairs"] if p["label"] == "measure1")["cameras"]
    rows = ["object,type,vertex,xl,yl,xr,yr,attribute"]
    for number, fish in enumerate(("fish1", "fish2"), start=1):
        for vertex, point in enumerate(("snout", "fork")):
            left, right = cameras["left"]["objects"][fish][point], cameras["right"]["objects"][fish][point]
            rows.append(f"{fish},line,{vertex},{left[0]:.3f},{left[1]:.3f},{right[0]:.3f},{right[1]:.3f},fish{number}")
    return "\n".join(rows) + "\n"


def _clicks() -> str:
    """A valid clicks file of a target field (side,id,x,y): eight control points of the ROV sample's pair
    water1 identified in each image, at their observed pixels."""
    rows = [line.split(",") for line in (ROV / "observations_water.csv").read_text().splitlines()[1:]]
    rows = [r for r in rows if r[5] == "water1"][:8]
    return "side,id,x,y\n" + "".join(f"{side},{r[0]},{r[1 + 2 * k]},{r[2 + 2 * k]}\n"
                                      for k, side in enumerate(("left", "right")) for r in rows)


def _opencv_file(path: Path) -> None:
    import cv2
    import numpy as np

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


def silent(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@functools.cache
def _detection_model(folder: Path) -> None:
    """A valid detection model: fish.toml describing fish.onnx, a tiny network giving one fish."""
    import numpy as np

    from tests.core.detection.onnx_models import constant_output_model

    table = np.array([[320.0, 320.0, 100.0, 40.0, 0.9, 280.0, 320.0, 0.9, 360.0, 320.0, 0.9]], np.float32).T[None]
    (folder / "fish.onnx").write_bytes(constant_output_model(table, 640, 640))
    (folder / "fish.toml").write_text('[model]\nfile = "fish.onnx"\nfamily = "yolo-pose"\ninput_width = 640\n'
                                      'input_height = 640\n\n[output]\nclasses = ["fish"]\n'
                                      'keypoints = ["snout", "fork"]\n')


def valid_inputs() -> Path:
    """The valid inputs every door starts from (a project with objects, calibrations, CSV files, images, a
    video, a sample folder …), made once per test session in a scratch folder removed at exit."""
    folder = Path(tempfile.mkdtemp(prefix="usvips-doors-"))
    atexit.register(shutil.rmtree, folder, True)
    copies = {"cal.json": ROV / "calibration.json", "cal_air.json": ROV / "calibration_air.json",
              "control.csv": ROV / "control.csv", "obs_air.csv": ROV / "observations_air.csv",
              "obs_water.csv": ROV / "observations_water.csv", "left.png": ROV / "images" / "measure1_left.png",
              "right.png": ROV / "images" / "measure1_right.png", "left.mp4": ROV / "video_left.mp4",
              "right.mp4": ROV / "video_right.mp4"}
    for name, source in copies.items():
        shutil.copy(source, folder / name)
    shutil.copytree(TANK, folder / "tank", ignore=shutil.ignore_patterns("project.usvips*"))
    (folder / "picks.csv").write_text(_picks())
    (folder / "clicks.csv").write_text(_clicks())
    (folder / "species.csv").write_text("family,genus,species,code,max_length_cm\n"
                                        "Sparidae,Pagrus,auratus,37353001,70\nLabridae,Coris,julis,,30\n")
    (folder / "geo.csv").write_text("id,latitude,longitude,depth\n1,-32.0,115.0,110\n2,-32.00001,115.00001,110\n"
                                    "3,-32.0,115.00002,110.5\n")  # the control points are 100 m down (Z)
    _opencv_file(folder / "stereo.yml")
    _detection_model(folder)
    scene = json.loads((ROV / "scene.json").read_text())
    for key in ("frame", "video", "description"):
        scene.pop(key)
    scene["image"] = {"width": 64, "height": 48, "supersample": 1}
    for side in ("left", "right"):
        scene[side].update({k: scene[side][k] / 10 for k in ("f", "xp", "yp")})
    scene["pairs"] = [p for p in scene["pairs"] if p["label"] == "measure1"]
    (folder / "scene.json").write_text(json.dumps(scene))
    for argv in (["project", "new", str(folder / "rov.usvips"), "--from", str(ROV)],
                 ["measure", "--project", str(folder / "rov.usvips"), "--pair", "measure1", "--picks",
                  str(folder / "picks.csv"), "--annotator", "A"],
                 ["target", "describe", "chessboard", "--cols", "8", "--rows", "5", "--square", "20", "--out",
                  str(folder / "target.json")]):
        code, _, err = silent(argv)
        assert code == 0, (argv, err)
    for companion in folder.glob("*.usvips-*"):
        companion.unlink()
    return folder


def _write(name: str, data: bytes | None = None, *, folder: bool = False) -> Callable[[Path], list[str]]:
    def make(work: Path) -> list[str]:
        path = work / name
        if folder:
            path.mkdir()
        elif data is not None:
            path.write_bytes(data)
        return [str(path)]
    return make


def _cut_points(text: bytes, rng: random.Random, count: int) -> list[int]:
    """Offsets at which the text is cut inside its content (not in trailing white space)."""
    end = len(text.rstrip())
    return sorted({rng.randrange(1, end) for _ in range(count)}) if end > 1 else []


def _csv_spoilings(valid: bytes, rng: random.Random, strict: bool) -> list[tuple[str, bytes]]:
    """A CSV file's spoilings; ``strict``: rows shorter than the header are wrong (else the missing fields
    are empty optional ones)."""
    lines = valid.decode().splitlines()
    header, rows = lines[0].split(","), [line.split(",") for line in lines[1:] if line.strip()]
    out: list[tuple[str, bytes]] = [("header only", (lines[0] + "\n").encode())]

    def text(head: list[str], body: list[list[str]]) -> bytes:
        return ("\n".join(",".join(r) for r in [head, *body]) + "\n").encode()

    for _ in range(3 if strict else 0):  # a row cut inside, before its last separator: fields missing
        r = rng.randrange(len(rows))
        line = ",".join(rows[r])
        cut = rng.randrange(0, line.rindex(","))
        out.append((f"cut in row {r + 2} at {cut}", text(header, rows[:r]) + line[:cut].encode()))
    column = rng.choice([i for i, h in enumerate(header) if h not in OPTIONAL_COLUMNS])
    out.append((f"column {header[column]!r} dropped",
                text([h for i, h in enumerate(header) if i != column],
                     [[v for i, v in enumerate(r) if i != column] for r in rows])))
    column = rng.randrange(len(header))
    out.append((f"column {header[column]!r} renamed",
                text([("zz" if i == column else h) for i, h in enumerate(header)], rows)))
    r = rng.randrange(len(rows))
    if strict:
        out.append((f"row {r + 2} short", text(header, [row[:-1] if i == r else row for i, row in enumerate(rows)])))
    numeric = [(i, j) for i, row in enumerate(rows) for j, v in enumerate(row)
               if _is_number(v) and header[j] not in LABEL_COLUMNS]
    for bad in ("nan", "inf", "-inf", "1e999", "1e300", "x", ""):
        cells = [(i, j) for i, j in numeric if bad or header[j] not in OPTIONAL_COLUMNS]  # '' leaves one out
        if not cells:
            continue
        i, j = rng.choice(cells)
        spoiled = [list(row) for row in rows]
        spoiled[i][j] = bad
        out.append((f"row {i + 2} {header[j]}={bad!r}", text(header, spoiled)))
    return out


#: columns that hold names (a point's id may be any text, "inf" too), not numbers
LABEL_COLUMNS = ("id", "object", "pair", "code", "label")
#: columns a file may leave out (dropping one leaves a valid file)
OPTIONAL_COLUMNS = ("attribute", "code", "max_length_cm", "pair", "depth")
#: files whose rows may be shorter than the header (a species list's trailing optional fields)
RAGGED = ("species.csv",)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _numeric_leaves(data, path=()):
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _numeric_leaves(value, (*path, key))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            yield from _numeric_leaves(value, (*path, i))
    elif isinstance(data, (int, float)) and not isinstance(data, bool):
        yield path


def _json_spoilings(valid: bytes, rng: random.Random) -> list[tuple[str, bytes]]:
    data = json.loads(valid)
    out = [(label, text.encode()) for label, text in
           (("a list", "[]"), ("a number", "42"), ("a string", '"x"'), ("null", "null"), ("{}", "{}"))]
    if isinstance(data.get("version"), int):
        out.append(("a future version", json.dumps({**data, "version": data["version"] + 100}).encode()))
    if isinstance(data.get("format"), str):
        out.append(("another format", json.dumps({**data, "format": "something-else"}).encode()))
    leaves = list(_numeric_leaves(data))
    for bad in ("NaN", "Infinity", "1e999", '"x"', "{}", "[]"):
        path = rng.choice(leaves)
        spoiled = json.loads(valid)
        parent = spoiled
        for key in path[:-1]:
            parent = parent[key]
        parent[path[-1]] = "\x00MARK"
        text = json.dumps(spoiled).replace('"\\u0000MARK"', bad)
        out.append((f"{'/'.join(map(str, path))}={bad}", text.encode()))
    return out


def file_spoilings(name: str, valid: Path, rng: random.Random) -> list[tuple[str, Callable[[Path], list[str]]]]:
    """Every way a file of this kind (by its name) is wrong, written as ``bad_NAME``."""
    bad = f"bad_{name}"
    cases: list[tuple[str, Callable]] = [("missing", _write(bad)), ("a folder", _write(bad, folder=True))]
    if valid.is_dir():  # a sample folder
        manifest = (valid / "project.json").read_bytes()

        def sample(content: bytes | None) -> Callable[[Path], list[str]]:
            def make(work: Path) -> list[str]:
                shutil.copytree(valid, work / bad)
                if content is None:
                    (work / bad / "project.json").unlink()
                else:
                    (work / bad / "project.json").write_bytes(content)
                return [str(work / bad)]
            return make

        cases += [("a file", _write(bad, b"id,X\n")), ("no project.json", sample(None)),
                  ("project.json empty", sample(b"")), ("project.json garbage", sample(rng.randbytes(300)))]
        cases += [(f"project.json {label}", sample(text)) for label, text in _json_spoilings(manifest, rng)]
        cases += [(f"project.json cut at {at}", sample(manifest[:at])) for at in _cut_points(manifest, rng, 3)]
        return cases
    data = valid.read_bytes()
    cases += [("empty", _write(bad, b""))]
    cases += [(f"garbage {i}", _write(bad, rng.randbytes(rng.randrange(64, 4000)))) for i in range(2)]
    suffix = valid.suffix
    if suffix in (".csv", ".json", ".yml"):
        at = rng.randrange(1, len(data.rstrip()))
        cases.append((f"not UTF-8 at {at}", _write(bad, data[:at] + b"\xe9\xff" + data[at:])))
    if suffix in (".json", ".yml"):  # (a CSV file cut at a line's end is a shorter valid file: cut inside rows)
        cases += [(f"cut at {at}", _write(bad, data[:at])) for at in _cut_points(data, rng, 3)]
    if suffix == ".csv":
        cases += [(label, _write(bad, text)) for label, text in _csv_spoilings(data, rng, name not in RAGGED)]
    elif suffix == ".json":
        cases += [(label, _write(bad, text)) for label, text in _json_spoilings(data, rng)]
    elif suffix in (".png", ".mp4"):
        cases += [(f"cut at {at}", _write(bad, data[:at])) for at in sorted({rng.randrange(8, len(data) // 2)
                                                                               for _ in range(2)})]
        cases += [("a text file", _write(bad, b"id,X,Y,Z\n1,2,3,4\n"))]
    elif suffix == ".usvips":
        def sqlite_file(make_it: Callable[[Path], None]) -> Callable[[Path], list[str]]:
            def make(work: Path) -> list[str]:
                make_it(work / bad)
                return [str(work / bad)]
            return make

        def not_a_project(path: Path) -> None:
            with contextlib.closing(sqlite3.connect(path)) as connection:
                connection.execute("CREATE TABLE fish (name TEXT)")
                connection.commit()

        def newer(path: Path) -> None:
            shutil.copy(valid, path)
            with contextlib.closing(sqlite3.connect(path)) as connection:
                version = connection.execute("PRAGMA user_version").fetchone()[0]
                connection.execute(f"PRAGMA user_version = {version + 50}")
                connection.commit()

        cases += [("a SQLite file not a project", sqlite_file(not_a_project)),
                  ("a newer schema", sqlite_file(newer)), ("a CSV file", _write(bad, b"id,X,Y,Z\n1,2,3,4\n")),
                  ("cut in half", _write(bad, data[: len(data) // 2]))]
    return cases


#: server addresses a person gets wrong; each with its password, never to be printed
BAD_URLS = [
    ("# and @ in the password, nothing listening", f"postgresql://fuzz:{PASSWORDS[0]}@127.0.0.1:1/survey"),
    ("a bad percent escape in the password", f"postgresql://fuzz:{PASSWORDS[1]}@127.0.0.1:1/survey"),
    ("no host", f"postgresql://fuzz:{PASSWORDS[2]}@/survey?host=/nonexistent/socket"),
    ("a port that is not a number", f"postgresql://fuzz:{PASSWORDS[2]}@127.0.0.1:port/survey"),
    ("a port out of range", f"postgresql://fuzz:{PASSWORDS[3]}@127.0.0.1:99999/survey"),
    ("a negative port", f"postgres://fuzz:{PASSWORDS[3]}@127.0.0.1:-5/survey"),
    ("a broken IPv6 host", f"postgresql://fuzz:{PASSWORDS[2]}@[::1/survey"),
    ("no database", f"postgresql://fuzz:{PASSWORDS[3]}@127.0.0.1:1"),
    ("a query port that is not a number", f"postgresql://fuzz:{PASSWORDS[2]}@127.0.0.1:1/survey?port=x"),
    ("an unknown connection option", f"postgresql://fuzz:{PASSWORDS[0]}@127.0.0.1:1/survey?bogus=1"),
]



def dump(project: Path) -> list[str]:
    """Every table of a project file, read without writing."""
    with contextlib.closing(sqlite3.connect(f"file:{project}?mode=ro", uri=True)) as connection:
        return list(connection.iterdump())
