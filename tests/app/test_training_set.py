"""Reviewed objects exported as a YOLO-pose training set: accepted lengths only (a person's and accepted
proposals), crops whose labels map back to the reviewed pixels, the reviewers' corrections of proposals,
and never a file written over (an existing folder refused, nothing left behind on an error)."""

import csv

import cv2
import numpy as np
import pytest

from tests.app.detection_scenes import fake_model, make_project, scene
from usvips.app.detection_service import detect_in_project
from usvips.app.training_set import export_training_set
from usvips.cli import main
from usvips.core.errors import UsvipsError
from usvips.io.atomic import OutputFileError
from usvips.store import Project
from usvips.store.project import Vertex


@pytest.fixture
def reviewed(tmp_path):
    path = make_project(tmp_path)
    truth = scene(seed=8, count=3)
    with Project.open(path) as project:
        run = detect_in_project(project, fake_model(truth), pair="dive", refine=False)
        first, second, third = (p.object_id for p in run.proposals)
        stored = project.object(first)
        moved = [Vertex(v.xl + 2.5, v.yl - 1.5, v.xr, v.yr, pair="dive") for v in stored.vertices]
        project.update_object(first, vertices=moved)        # a reviewer corrects the left keypoints
        project.set_review(first, "accepted")
        project.set_review(second, "accepted")
        project.set_review(third, "flagged", "not a fish")  # rejected: not exported
        person = project.add_object("length", [Vertex(300.0, 400.0, 100.0, 410.0, pair="dive"),
                                               Vertex(420.0, 430.0, 215.0, 440.0, pair="dive")], "Pagrus auratus")
        project.set_review(person, "accepted")
    return path, first, second, person


def _rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_accepted_lengths_become_crops_with_labels_and_the_corrections_are_kept(reviewed, tmp_path):
    path, first, second, person = reviewed
    out = tmp_path / "training"
    with Project.open(path) as project:
        written, corrections, skipped = export_training_set(project, out)
        objects = {i: project.object(i) for i in (first, second, person)}
    assert (written, corrections, skipped) == (6, 8, [])
    assert sorted(p.name for p in (out / "images").iterdir()) == sorted(
        f"{i}_{c}.png" for i in (first, second, person) for c in ("left", "right"))
    for sample in _rows(out / "samples.csv"):
        name = sample["image"].split("/")[1][:-4]
        crop = cv2.imread(str(out / sample["image"]))
        numbers = [float(v) for v in (out / "labels" / f"{name}.txt").read_text().split()]
        assert numbers[0] == 0 and numbers[7] == numbers[10] == 2
        size = np.array([crop.shape[1], crop.shape[0]])
        origin = np.array([float(sample["crop_x0"]), float(sample["crop_y0"])])
        points = np.array([numbers[5:7], numbers[8:10]]) * size - 0.5 + origin
        stored = objects[int(sample["object"])]
        keys = ("xl", "yl") if sample["camera"] == "left" else ("xr", "yr")
        expected = np.array([(getattr(v, keys[0]), getattr(v, keys[1])) for v in stored.vertices])
        np.testing.assert_allclose(points, expected, atol=2e-3)
        box = np.array(numbers[1:5])
        assert np.all((box > 0) & (box <= 1))
    rows = _rows(out / "corrections.csv")
    assert {int(r["object"]) for r in rows} == {first, second}  # a person's object has no proposal
    moved = [r for r in rows if int(r["object"]) == first and r["camera"] == "left"]
    assert all(abs(float(r["reviewed_x"]) - float(r["proposed_x"]) - 2.5) < 1e-3 for r in moved)
    assert all(r["model"] == "fake-fish sha256:abababababab" for r in rows)
    assert "kpt_shape: [2, 3]" in (out / "dataset.yaml").read_text()


def test_nothing_is_written_over_and_nothing_is_left_behind(reviewed, tmp_path, capsys):
    path, *_ = reviewed
    out = tmp_path / "taken"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    with Project.open(path) as project, pytest.raises(OutputFileError, match="never over files"):
        export_training_set(project, out)
    assert [p.name for p in out.iterdir()] == ["mine.txt"]
    assert main(["project", "export", str(path), str(tmp_path / "set"), "--format", "training-set"]) == 0
    assert "exported 6 samples" in capsys.readouterr().out
    with Project.open(path) as project:
        for review in project.reviews("accepted"):
            project.set_review(review.object_id, "flagged", "not sure")
        with pytest.raises(UsvipsError, match="no accepted"):
            export_training_set(project, tmp_path / "empty")
    assert not list(tmp_path.glob(".empty-*")) and not (tmp_path / "empty").exists()
