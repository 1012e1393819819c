"""Reviewed objects exported as a training set for a keypoint model, in the YOLO-pose layout, with the
reviewers' corrections of the model's proposals beside it.

What is exported: every ACCEPTED ``length`` object (a person's, or a model's proposal a reviewer accepted)
of two vertices — snout then fork — on an image pair or a video frame; each camera's image gives one
sample. The layout of the folder ``OUT`` (made; it must not exist, or be an empty folder):

    images/<object id>_<left|right>.png   a crop of the image around the fish
    labels/<object id>_<left|right>.txt   one YOLO-pose line: 0 cx cy w h  sx sy 2  fx fy 2
                                          (class 0 "fish"; box centre and size, then snout and fork with
                                          visibility 2, all as fractions of the crop's width and height)
    corrections.csv                       object, camera, keypoint, proposed_x, proposed_y, reviewed_x,
                                          reviewed_y, model (pixels of the whole image) — one row per keypoint
                                          of each accepted proposal, moved by its reviewer or not
    samples.csv                           image, object, camera, crop_x0, crop_y0: where each crop's top-left
                                          pixel lies in the whole image (pixels)
    dataset.yaml                          the YOLO dataset file: path, train, val, names, kpt_shape [2, 3]
    README.txt                            this layout, in words

The crop: the keypoints' extent padded by half the snout-fork length (pixels) on every side, clipped to
the image. The box: the keypoints' extent padded by a fifth of that length across the fish and along it —
the body's outline is not stored, so the box is a stated convention, not a traced outline. Pixel
coordinates follow USVIPS (origin at the centre of the top-left pixel); YOLO's fractions are of the crop,
from its top-left CORNER: (x + 0.5) / width.

The folder is written beside ``OUT`` under a temporary name and renamed into place when whole: an error
leaves nothing behind, and nothing that exists is written over.
"""

from __future__ import annotations

import csv
import io
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from usvips.app.video_project import open_streams, partner_frame
from usvips.core.errors import UsvipsError
from usvips.io.atomic import OutputFileError
from usvips.io.images import read_image
from usvips.store.interface import ProjectStore
from usvips.store.records import StoredObject

KEYPOINTS = ("snout", "fork")
#: the crop's margin and the box's padding, as fractions of the snout-fork length in pixels
CROP_MARGIN, BOX_PADDING = 0.5, 0.2


@dataclass(frozen=True)
class Sample:
    """One camera's image of one reviewed fish: the object's id, the camera, its snout and fork pixels as
    reviewed (2, 2), and as the model proposed them (None for a person's object)."""

    object_id: int
    camera: str
    reviewed: np.ndarray
    proposed: np.ndarray | None
    model: str = ""


def reviewed_samples(project: ProjectStore) -> tuple[list[tuple[StoredObject, list[Sample]]], list[str]]:
    """The accepted two-vertex length objects with their samples (left and right), and why others were left
    out (one line each)."""
    accepted = sorted(r.object_id for r in project.reviews("accepted"))
    out, skipped = [], []
    for stored in project.objects_with_ids(accepted):
        if stored.kind != "length" or len(stored.vertices) != 2 or stored.vertices[0].pair is None:
            skipped.append(f"object {stored.id}: not a snout-fork length on a pair or video frame")
            continue
        added = next((h for h in project.history(stored.id) if h.change == "add"), None)
        first = (added.new or {}).get("vertices", []) if added is not None else []
        sources = [str(v.get("source", "")) for v in first]
        from_model = len(first) == 2 and all(s.startswith("keypoint (") and "model " in s for s in sources)
        model = sources[0].split("model ", 1)[1].rstrip(")").split(",", 1)[0] if from_model else ""
        samples = []
        for camera, keys in (("left", ("xl", "yl")), ("right", ("xr", "yr"))):
            reviewed = np.array([(getattr(v, keys[0]), getattr(v, keys[1])) for v in stored.vertices], float)
            proposed = np.array([(float(v[keys[0]]), float(v[keys[1]])) for v in first]) if from_model else None
            samples.append(Sample(stored.id, camera, reviewed, proposed, model))
        out.append((stored, samples))
    return out, skipped


def _images(project: ProjectStore, stored: StoredObject, cache: dict) -> dict[str, np.ndarray]:
    """The object's left and right images, 8-bit BGR (or grey), read once per pair or video frame."""
    vertex = stored.vertices[0]
    key = (vertex.pair, vertex.frame_left if vertex.video is not None else None)
    if key in cache:
        return cache[key]
    if vertex.video is not None:
        video, left, right = open_streams(project, vertex.video)
        with left, right:
            frame = int(vertex.frame_left)
            images = {"left": left.frame(frame), "right": right.frame(partner_frame(video, frame, right.frame_count))}
    else:
        pair = next((p for p in project.pairs() if p.label == vertex.pair), None)
        if pair is None or pair.left is None or pair.right is None:
            raise UsvipsError(f"object {stored.id}: pair {vertex.pair!r} has no image files")
        images = {"left": read_image(project.media_location(pair.left)),
                  "right": read_image(project.media_location(pair.right))}
    for side, image in images.items():
        if image.dtype == np.uint16:
            image = (image >> 8).astype(np.uint8)
        images[side] = cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if image.ndim == 3 else image
    cache.clear()  # one pair or frame at a time: objects come sorted by id, mostly pair by pair
    cache[key] = images
    return images


def crop_and_label(image: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, str, tuple[int, int]]:
    """The crop of ``image`` around a fish whose snout and fork are ``points`` (2, 2) px, its YOLO-pose
    label line (see the module docstring) and the crop's top-left pixel in the image."""
    h, w = image.shape[:2]
    length = max(float(np.linalg.norm(points[1] - points[0])), 1.0)
    low = np.floor(points.min(axis=0) - CROP_MARGIN * length).astype(int)
    high = np.ceil(points.max(axis=0) + CROP_MARGIN * length).astype(int)
    x0, y0 = max(low[0], 0), max(low[1], 0)
    x1, y1 = min(high[0], w - 1), min(high[1], h - 1)
    crop = image[y0:y1 + 1, x0:x1 + 1]
    cw, ch = crop.shape[1], crop.shape[0]
    local = points - (x0, y0) + 0.5  # to the crop's corner-based coordinates
    box_low = np.clip(local.min(axis=0) - BOX_PADDING * length, 0, (cw, ch))
    box_high = np.clip(local.max(axis=0) + BOX_PADDING * length, 0, (cw, ch))
    centre, size = (box_low + box_high) / 2, box_high - box_low
    scale = np.array([cw, ch], float)
    parts = [f"{v:.6f}" for v in (*(centre / scale), *(size / scale))]
    for x, y in np.clip(local / scale, 0, 1):
        parts += [f"{x:.6f}", f"{y:.6f}", "2"]
    return crop, "0 " + " ".join(parts), (int(x0), int(y0))


README = __doc__.split("The layout of the folder ``OUT``", 1)[1]


def export_training_set(project: ProjectStore, out: str | Path,
                        progress: Callable[[int, int], None] | None = None) -> tuple[int, int, list[str]]:
    """Write the training set of ``project``'s reviewed objects to the folder ``out`` (see the module
    docstring); returns (samples written, corrections written, why objects were left out)."""
    out = Path(out)
    if out.exists() and not (out.is_dir() and not any(out.iterdir())):
        raise OutputFileError(str(out), "exists: the training set is written to a new (or empty) folder, never "
                                        "over files")
    if not out.parent.is_dir():
        raise OutputFileError(str(out), f"its folder {out.parent} does not exist")
    objects, skipped = reviewed_samples(project)
    if not objects:
        raise UsvipsError("no accepted snout-fork length to export (review the objects first: only accepted "
                          "ones are a training set)")
    work = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    try:
        (work / "images").mkdir()
        (work / "labels").mkdir()
        rows = io.StringIO()
        table = csv.writer(rows, lineterminator="\n")
        table.writerow(["object", "camera", "keypoint", "proposed_x", "proposed_y", "reviewed_x", "reviewed_y",
                        "model"])
        cache: dict = {}
        crops = ["image,object,camera,crop_x0,crop_y0"]
        written = corrections = 0
        for done, (stored, samples) in enumerate(objects, start=1):
            images = _images(project, stored, cache)
            for sample in samples:
                crop, label, origin = crop_and_label(images[sample.camera], sample.reviewed)
                name = f"{sample.object_id}_{sample.camera}"
                crops.append(f"images/{name}.png,{sample.object_id},{sample.camera},{origin[0]},{origin[1]}")
                if not cv2.imwrite(str(work / "images" / f"{name}.png"), crop):
                    raise OutputFileError(str(out), f"cannot write the crop {name}.png")
                (work / "labels" / f"{name}.txt").write_text(label + "\n")
                written += 1
                if sample.proposed is not None:
                    for k, point in enumerate(KEYPOINTS):
                        table.writerow([sample.object_id, sample.camera, point,
                                        *(f"{v:.3f}" for v in sample.proposed[k]),
                                        *(f"{v:.3f}" for v in sample.reviewed[k]), sample.model])
                        corrections += 1
            if progress is not None:
                progress(done, len(objects))
        (work / "corrections.csv").write_text(rows.getvalue())
        (work / "samples.csv").write_text("\n".join(crops) + "\n")
        (work / "dataset.yaml").write_text("path: .\ntrain: images\nval: images\nnames:\n  0: fish\n"
                                           "kpt_shape: [2, 3]\nflip_idx: [0, 1]\n")
        (work / "README.txt").write_text("A training set exported by USVIPS from reviewed objects.\n"
                                         + README.replace("``", ""))
        if out.exists():
            out.rmdir()
        work.rename(out)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    return written, corrections, skipped
