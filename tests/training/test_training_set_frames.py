"""A reviewed training set read back as the fish model's training frames: made by the real exporter from a
project, each crop becomes one input frame whose fish lies at the reviewed pixels, with its caudal tips
unknown (ignored by the targets, not taught as absent); a bad export is refused in one line naming the file
and line."""

import csv
import shutil

import cv2
import numpy as np
import pytest

from tests.app.detection_scenes import make_project, scene
from usvips.app.training_set import export_training_set
from usvips.core.errors import UsvipsError
from usvips.store import Project
from usvips.store.project import Vertex
from usvips.training.fish_targets import INPUT, STRIDE, targets
from usvips.training.training_set_frames import PAD_VALUE, read_training_set


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """An export of eight accepted lengths (a person's, at the scenes' true pixels) and the pixels reviewed."""
    folder = tmp_path_factory.mktemp("reviewed")
    path = make_project(folder)
    reviewed = {}
    with Project.open(path) as project:
        for seed in (3, 4, 5):
            truth = scene(seed=seed, count=3 if seed < 5 else 1)
            for left, right in zip(truth.left, truth.right, strict=True):
                object_id = project.add_object("length", [Vertex(*left[k], *right[k], pair="dive") for k in (0, 1)])
                project.set_review(object_id, "accepted")
                reviewed[object_id] = {"left": left, "right": right}
        small = {"left": np.array([[300.0, 400.0], [345.0, 412.0]]),
                 "right": np.array([[100.0, 410.0], [144.0, 421.0]])}
        object_id = project.add_object("length", [Vertex(*small["left"][k], *small["right"][k], pair="dive")
                                                  for k in (0, 1)])  # a crop smaller than the input
        project.set_review(object_id, "accepted")
        reviewed[object_id] = small
        out = folder / "training"
        written, _, _ = export_training_set(project, out)
    assert written == 2 * len(reviewed) == 16
    return out, reviewed


def _samples(out):
    with open(out / "samples.csv", newline="") as handle:
        return {row["image"].split("/")[1]: row for row in csv.DictReader(handle)}


def test_each_crop_becomes_a_frame_whose_fish_lies_at_the_reviewed_pixels(exported):
    out, reviewed = exported
    frames = read_training_set(out)
    samples = _samples(out)
    assert sorted(frames.names) == sorted(samples) and frames.images.shape == (16, INPUT, INPUT, 3)
    assert frames.record()["samples"] == 16 and frames.record()["required"] == 16
    for image, fish, name in zip(frames.images, frames.fish, frames.names, strict=True):
        row = samples[name]
        crop = cv2.imread(str(out / row["image"]))
        h, w = crop.shape[:2]
        scale = min(1.0, INPUT / w, INPUT / h)  # fitted when larger, never enlarged
        nw, nh = round(w * scale), round(h * scale)
        pad = np.array([(INPUT - nw) // 2, (INPUT - nh) // 2])
        # the reviewed pixel (centre origin, whole image) → the input (corner origin)
        pixels = reviewed[int(row["object"])][row["camera"]]
        expected = (pixels - (float(row["crop_x0"]), float(row["crop_y0"])) + 0.5) * (nw / w, nh / h) + pad
        (f,) = fish
        np.testing.assert_allclose(f["keypoints"][:2], expected, atol=0.01)
        assert np.isnan(f["keypoints"][2:]).all()
        assert f["known"].tolist() == [True, True, False, False] and f["visible"][:2].all() and f["required"]
        u0, v0, u1, v1 = f["box"]
        assert u0 < expected[:, 0].min() and u1 > expected[:, 0].max()
        assert v0 < expected[:, 1].min() and v1 > expected[:, 1].max()
        inside = image[pad[1]:pad[1] + nh, pad[0]:pad[0] + nw]
        np.testing.assert_array_equal(inside, cv2.resize(crop, (nw, nh), interpolation=cv2.INTER_LINEAR))
        outside = image.copy()
        outside[pad[1]:pad[1] + nh, pad[0]:pad[0] + nw] = PAD_VALUE
        assert (outside == PAD_VALUE).all()
    fitted = {min(INPUT / c.shape[1], INPUT / c.shape[0]) < 1 for c in (cv2.imread(str(p)) for p in
                                                                       (out / "images").iterdir())}
    assert fitted == {True, False}  # crops fitted down and crops kept at their size were both checked


def test_a_reviewed_crop_teaches_its_fish_only_and_its_caudal_tips_not_at_all(exported):
    """Other fish, unlabelled, may lie in a crop: its heatmaps' negatives are taught only inside its fish's
    box; the caudal tips are not labelled: their heatmaps and displacements are not taught; snout, fork and
    centre peaks are."""
    out, _ = exported
    frames = read_training_set(out)
    for fish in frames.fish:
        for flip in (False, True):
            t = targets(fish, flip)
            (f,) = fish
            u0, v0, u1, v1 = np.array(f["box"]) / STRIDE
            if flip:
                u0, u1 = INPUT // STRIDE - u1, INPUT // STRIDE - u0
            rows, cols = np.nonzero(t["ignore"])
            assert len(rows) and (rows >= np.floor(v0)).all() and (rows <= np.ceil(v1)).all()
            assert (cols >= np.floor(u0)).all() and (cols <= np.ceil(u1)).all()
            i, j = np.unravel_index(np.argmax(t["centre_heat"]), t["centre_heat"].shape)
            assert t["ignore"][i, j] == 1 and t["centre_heat"][i, j] == 1.0  # its peak is shaped
            assert (t["keypoint_ignore"][2:] == 0).all() and (t["keypoint_heat"][2:] == 0).all()
            assert t["keypoint_heat"][:2].max(axis=(1, 2)).tolist() == [1.0, 1.0]
            assert (t["displacement_mask"][4:] == 0).all() and (t["displacement_mask"][:4].sum(axis=(1, 2)) > 0).all()
            assert t["centre_mask"].sum() == 1


def _rendered_fish(rng):
    """A fish dict as the rendered cache holds it (no ``known``): four keypoints in the input."""
    snout = rng.uniform(40, INPUT - 40, 2)
    body = rng.uniform(15, 60) * np.array([np.cos(a := rng.uniform(0, 2 * np.pi)), np.sin(a)])
    fork = snout + body
    across = np.array([-body[1], body[0]]) * 0.15
    points = np.array([snout, fork, fork + 0.1 * body + across, fork + 0.1 * body - across])
    low, high = points.min(axis=0) - 3, points.max(axis=0) + 3
    return {"keypoints": points, "visible": rng.uniform(size=4) < 0.8, "in_frame": rng.uniform(size=4) < 0.9,
            "box": (*low, *high), "required": bool(rng.uniform() < 0.8)}


def test_a_rendered_frame_is_taught_as_before_and_a_mixed_frame_ignores_only_the_unknown_keypoints():
    rng = np.random.default_rng(11)
    for _ in range(40):
        fish = [_rendered_fish(rng) for _ in range(int(rng.integers(1, 5)))]
        flip = bool(rng.uniform() < 0.5)
        plain = targets(fish, flip)
        told = targets([{**f, "known": np.ones(4, bool)} for f in fish], flip)
        assert plain.keys() == told.keys()
        for key in plain:
            np.testing.assert_array_equal(plain[key], told[key])
        np.testing.assert_array_equal(plain["keypoint_ignore"], np.stack([plain["ignore"]] * 4))
        # one fish without its caudal tips: those two heatmaps are ignored over the frame, the rest unchanged
        unknown = {**_rendered_fish(rng), "known": np.array([True, True, False, False])}
        unknown["in_frame"] = np.array([True, True, False, False])
        mixed = targets([*fish, unknown], flip)
        assert (mixed["keypoint_ignore"][2:] == 0).all()
        np.testing.assert_array_equal(mixed["keypoint_ignore"][:2], np.stack([mixed["ignore"]] * 2))
        assert mixed["ignore"].mean() > 0.5  # a rendered frame's background is taught
        # a fish from a frame whose other fish are not labelled: no negatives taught anywhere on the frame
        partial = targets([*fish, {**unknown, "background_known": False}], flip)
        assert (partial["ignore"] <= mixed["ignore"]).all() and (partial["keypoint_ignore"][2:] == 0).all()
        assert partial["ignore"].sum() < 0.5 * mixed["ignore"].sum()  # taught only in that fish's box
        np.testing.assert_array_equal(partial["centre_heat"], mixed["centre_heat"])
        g = INPUT // STRIDE
        assert mixed["keypoint_heat"].shape == (4, g, g)


def _image(copy):
    return sorted((copy / "images").iterdir())[0]


def _label(copy):
    return copy / "labels" / f"{_image(copy).stem}.txt"


GOOD = "0 0.5 0.5 0.2 0.2 0.1 0.1 2 0.9 0.9 2"


@pytest.mark.parametrize(("spoil", "names", "words"), [
    (lambda c: _label(c).unlink(), "label", "missing (the label of"),
    (lambda c: _label(c).write_text(GOOD[:-2] + "\n"), "label", ":1: 10 values, expected 11"),
    (lambda c: _label(c).write_text(f"{GOOD}\n" + GOOD.replace("0.9 0.9", "1.2 0.9") + "\n"), "label",
     ":2: a box or keypoint fraction outside 0..1"),
    (lambda c: _label(c).write_text(GOOD.replace("0.1 0.1", "0.1 -0.1")), "label", ":1: a box or keypoint fraction"),
    (lambda c: _label(c).write_text(GOOD.replace("0.2 0.2", "0.2 nan")), "label", ":1: a box or keypoint fraction"),
    (lambda c: _label(c).write_text(GOOD.replace("0.9 0.9", "0.9 x")), "label", ":1: not a number"),
    (lambda c: _label(c).write_text("1" + GOOD[1:]), "label", ":1: class 1, expected 0"),
    (lambda c: _label(c).write_text(GOOD.replace("0.1 2", "0.1 3")), "label", ":1: a keypoint visibility"),
    (lambda c: _label(c).write_text("\n\n"), "label", ": no label line"),
    (lambda c: _image(c).write_bytes(b"not a png"), "image", ": not an image OpenCV can read"),
    (lambda c: shutil.rmtree(c / "images"), "folder", ": not a training set (no images folder"),
])
def test_a_bad_export_is_refused_in_one_line_naming_the_file(exported, tmp_path, spoil, names, words):
    copy = tmp_path / "copy"
    shutil.copytree(exported[0], copy)
    named = {"label": _label(copy), "image": _image(copy), "folder": copy}[names]
    assert read_training_set(copy).names  # the copy reads before it is spoilt
    spoil(copy)
    with pytest.raises(UsvipsError) as caught:
        read_training_set(copy)
    message = str(caught.value)
    assert message.startswith(str(named)) and words in message and "\n" not in message


def test_a_held_out_share_keeps_both_images_of_a_fish_on_one_side(exported):
    out, reviewed = exported
    frames = read_training_set(out)
    for share, seed in ((0.25, 7), (0.5, 8), (0.0, 9)):
        trained, held = frames.split(share, seed)
        objects = [{name.split("_")[0] for name in part.names} for part in (trained, held)]
        assert not objects[0] & objects[1] and objects[0] | objects[1] == {str(i) for i in reviewed}
        assert len(objects[1]) == round(share * len(reviewed)) and len(held.names) == 2 * len(objects[1])
        for part in (trained, held):
            assert len(part.images) == len(part.fish) == len(part.names)
            for image, name in zip(part.images, part.names, strict=True):
                np.testing.assert_array_equal(image, frames.images[frames.names.index(name)])
        again = frames.split(share, seed)[1]
        assert again.names == held.names
