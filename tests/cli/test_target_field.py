"""``usvips target field``: on rendered stereo pairs of a 3-D disc field (air by a DLT, a flat port with an
earlier calibration), the table of found / doubtful / missing targets, ``--store`` keeping the found
ones where their discs are, a wrong id flagged, and every bad input one line, exit 2, nothing stored."""

import re

import numpy as np
import pytest

from tests.app.field_scenes import field_project, stereo_field
from usvips.cli import main
from usvips.io.field_clicks import write_clicks
from usvips.store.opening import open_project


def _stored(path, role="calibration-air"):
    with open_project(path, read_only=True) as project:
        return project.control_observations(role, "p1"), len(project.control())


@pytest.mark.parametrize("housing,calibration,distance,seed", [("air", None, 1.8, 1), ("air", None, 2.0, 2),
                                                               ("flat-port", "active", 2.6, 3),
                                                               ("flat-port", "id", 2.4, 4)])
def test_field_found_printed_and_stored(tmp_path, capsys, housing, calibration, distance, seed):
    rng = np.random.default_rng(seed + 500)
    scene = stereo_field(rng, housing, distance)
    path, calibration_id = field_project(tmp_path, scene, calibrated=calibration is not None)
    role = "calibration-water" if scene.water else "calibration-air"
    options = []
    if calibration is not None:
        if calibration == "active":
            with open_project(path) as project:
                project.activate_calibration("p1", calibration_id)
        options = ["--calibration", "active" if calibration == "active" else str(calibration_id)]
    clicks = tmp_path / "clicks.csv"
    write_clicks(clicks, scene.clicks(rng, 8, 1.5))
    command = ["target", "field", str(path), "--pair", "p1", "--clicks", str(clicks), *options]
    assert main(command) == 0
    out = capsys.readouterr().out
    assert f"({role})" in out and " left: " in out and "right: " in out
    assert "nothing stored" in out and len(_stored(path, role)[0]) == 0
    assert main([*command, "--store"]) == 0
    out = capsys.readouterr().out
    stored, _ = _stored(path, role)
    assert f"stored {len(stored)} targets as the {role} observations of pair p1" in out
    assert len(stored) >= 8
    for i, pid in enumerate(stored.ids):
        k = scene.control.ids.index(pid)
        for side, pixels in (("left", stored.left), ("right", stored.right)):
            assert np.hypot(*(pixels[i] - scene.truth[side][k])) < 0.5, (pid, side)
    # every doubtful or missing target is listed with its reason
    listed = [line for line in out.splitlines() if line.startswith(("  doubtful ", "  missing "))]
    counts = [int(doubtful) + int(missing) for doubtful, missing in
              re.findall(r"^(?: left|right): \d+ found, (\d+) doubtful, (\d+) missing", out, re.MULTILINE)]
    assert len(counts) == 2
    assert len(listed) == sum(counts) and all(line.split(": ", 1)[1] for line in listed)


def test_a_wrong_id_is_listed_and_stored_only_when_accepted(tmp_path, capsys):
    rng = np.random.default_rng(601)
    scene = stereo_field(rng, "air", 1.8)
    path, _ = field_project(tmp_path, scene)
    clicks = scene.clicks(rng, 8, 1.0)
    free = [i for i in np.flatnonzero(scene.visible["left"]) if scene.control.ids[i] not in clicks["left"]]
    wrong = next(iter(clicks["left"]))
    clicks["left"][wrong] = tuple(scene.truth["left"][free[0]])
    write_clicks(tmp_path / "clicks.csv", clicks)
    command = ["target", "field", str(path), "--pair", "p1", "--clicks", str(tmp_path / "clicks.csv"), "--store"]
    assert main(command) == 0
    out = capsys.readouterr().out
    assert f"  doubtful left {wrong}: clicked, but " in out and "check its id" in out
    assert wrong not in _stored(path)[0].ids
    assert main([*command, "--accept-doubtful", wrong]) == 0
    stored = _stored(path)[0]
    if wrong in stored.ids:  # accepted where it was clicked (when the right image found it)
        assert np.allclose(stored.left[stored.ids.index(wrong)], scene.truth["left"][free[0]], atol=0.5)
    else:
        assert "usable in one image only" in capsys.readouterr().out


def test_bad_input_is_one_line_and_stores_nothing(tmp_path, capsys):
    rng = np.random.default_rng(701)
    scene = stereo_field(rng, "air", 1.8)
    path, _ = field_project(tmp_path, scene)
    good = scene.clicks(rng, 7, 1.0)
    first = next(iter(good["left"]))

    def clicks(name, pixels):
        write_clicks(tmp_path / name, pixels)
        return str(tmp_path / name)

    cases = {
        "few": ([clicks("few.csv", {"left": dict(list(good["left"].items())[:5]), "right": good["right"]})],
                "few.csv: left image: 5 targets identified; at least 6 are needed (1 more)"),
        "unknown": ([clicks("unknown.csv", {**good, "right": {**good["right"], "Q1": (5.0, 5.0)}})],
                    "unknown.csv, line 16: right image: target 'Q1' is not a control point"),
        "outside": ([clicks("outside.csv", {**good, "left": {**good["left"], first: (12.0, 400.0)}})],
                    f"outside.csv, line 2: left image: target '{first}' at (12, 400) lies outside the image"),
        "coplanar": ([clicks("flat.csv", scene.clicks(rng, 6, 1.0, planar_only=True))], "lie in one plane"),
        "accept without store": ([clicks("ok.csv", good), "--accept-doubtful", first],
                                 "--accept-doubtful: only with --store"),
        "accept a found one": ([clicks("ok.csv", good), "--store", "--accept-doubtful", "T25,"],
                               "--accept-doubtful: target 'T25' is not doubtful"),
        "calibration": ([clicks("ok.csv", good), "--calibration", "abc"], "--calibration: 'abc' is neither"),
        "no active": ([clicks("ok.csv", good), "--calibration", "active"], "pair 'p1' has no active calibration"),
    }
    for name, (arguments, message) in cases.items():
        code = main(["target", "field", str(path), "--pair", "p1", "--clicks", *arguments])
        err = capsys.readouterr().err
        assert code == 2, name
        assert message in err and err.count("\n") == 1, (name, err)
        assert len(_stored(path)[0]) == 0
    assert main(["target", "field", str(path), "--pair", "p7", "--clicks", clicks("ok.csv", good)]) == 2
    assert "no image pair 'p7'" in capsys.readouterr().err
    (tmp_path / "side.csv").write_text("side,id,x,y\nmiddle,T00,1,2\n")
    assert main(["target", "field", str(path), "--pair", "p1", "--clicks", str(tmp_path / "side.csv")]) == 2
    assert "side.csv, line 2: side 'middle' is neither left nor right" in capsys.readouterr().err
