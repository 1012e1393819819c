"""A reviewed training set (``usvips project export PROJECT OUT --format training-set``, see
:mod:`usvips.app.training_set` and docs/detection.md) read as training frames of the fish keypoint model —
the same form as its rendered frames (numpy and OpenCV only; no PyTorch).

Each crop ``images/<name>.png`` becomes one INPUT × INPUT × 3 BGR uint8 frame: the crop centred in the input,
scaled down to fit when it is larger and never enlarged (a fish keeps its size in pixels, as the model meets it
in a frame; the training's zoom augmentation varies it), the rest grey 114 as the letterbox pads. Its label
``labels/<name>.txt`` holds one YOLO-pose line per fish, ``class cx cy w h  sx sy sv  fx fy fv``: class 0, the
box's centre and size and the snout and fork with their visibility (0 not labelled, 1 labelled but hidden,
2 visible), all fractions 0..1 of the crop from its top-left corner. Each becomes a fish dict of
:mod:`usvips.training.fish_targets` whose caudal tips are not ``known`` (the export stores snout and fork only).
A fish is one to find (``required``) when snout and fork are visible and at least
:data:`~usvips.training.fish_augment.MIN_REQUIRED_PX` input pixels apart.

A crop teaches background only inside its fish's box (``background_known`` False,
:func:`usvips.training.fish_targets.targets`): a crop is the reviewed fish padded by half its length, and other
fish, which nobody accepted or which were accepted as objects of their own, often lie in it (on 80 crops of
rendered survey clips the shipped model made 27 detections away from the labelled fish, those looked at
mostly on other fish); the rendered frames teach what is not a fish.

A bad export is refused in one line naming the file (and line): no ``images`` folder or no crops, a crop
that does not read, a crop without its label, a label line of the wrong layout or with a fraction outside
0..1.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from usvips.core.detection.letterbox import Letterbox
from usvips.core.errors import UsvipsError
from usvips.core.synth.fish_scene import KEYPOINTS
from usvips.training.fish_augment import MIN_REQUIRED_PX
from usvips.training.fish_targets import INPUT

#: the label's keypoints, in the order of the model's KEYPOINTS (the first two)
LABELLED = ("snout", "fork")
PAD_VALUE = 114
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


@dataclass(frozen=True)
class TrainingSet:
    """A training set read as frames: its folder, the frames (N × INPUT × INPUT × 3, BGR uint8), each frame's
    fish and the crop each frame came from."""

    folder: Path
    images: np.ndarray
    fish: list[list[dict]]
    names: list[str]

    @property
    def fish_count(self) -> int:
        return sum(len(f) for f in self.fish)

    def record(self) -> dict:
        """What training.json keeps of it: the folder, the crops and the fish (and those to find)."""
        return {"path": str(self.folder.resolve()), "samples": len(self.names), "fish": self.fish_count,
                "required": sum(bool(f["required"]) for frame in self.fish for f in frame)}

    def subset(self, keep: np.ndarray) -> TrainingSet:
        """The frames where ``keep`` (a boolean per frame) is True."""
        return TrainingSet(self.folder, self.images[keep], [f for f, k in zip(self.fish, keep, strict=True) if k],
                           [n for n, k in zip(self.names, keep, strict=True) if k])

    def split(self, share: float, seed: int) -> tuple[TrainingSet, TrainingSet]:
        """(trained on, held out): about ``share`` of the objects held out, drawn from ``seed``. Crops are
        grouped by object (their name up to its last ``_``: ``<object id>_<left|right>``), so a fish's two
        images are never split between the two parts."""
        objects = [name.rsplit(".", 1)[0].rsplit("_", 1)[0] for name in self.names]
        unique = sorted(set(objects))
        order = np.random.default_rng(seed).permutation(len(unique))
        held = {unique[i] for i in order[:round(share * len(unique))]}
        keep = np.array([o not in held for o in objects], bool)
        return self.subset(keep), self.subset(~keep)


def parse_label(line: str, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One YOLO-pose label line → the box (cx, cy, w, h), the keypoints (2, 2) and their visibility (2),
    fractions of the crop; ``where`` names the file and line in the error of a bad one."""
    parts = line.split()
    expected = 5 + 3 * len(LABELLED)
    if len(parts) != expected:
        raise UsvipsError(f"{where}: {len(parts)} values, expected {expected} "
                          "(class cx cy w h, then x y visibility for snout and fork)")
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise UsvipsError(f"{where}: not a number in {line.strip()!r}") from None
    if values[0] != 0:
        raise UsvipsError(f"{where}: class {parts[0]}, expected 0 (fish)")
    box = values[1:5]
    points = values[5:].reshape(len(LABELLED), 3)
    fractions = np.concatenate([box, points[:, :2].ravel()])
    if not np.all(np.isfinite(fractions)) or np.any(fractions < 0) or np.any(fractions > 1):
        raise UsvipsError(f"{where}: a box or keypoint fraction outside 0..1 in {line.strip()!r}")
    if not set(points[:, 2].tolist()) <= {0.0, 1.0, 2.0}:
        raise UsvipsError(f"{where}: a keypoint visibility other than 0, 1 or 2 in {line.strip()!r}")
    return box, points[:, :2], points[:, 2].astype(int)


def frame_from_crop(crop: np.ndarray, labels: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
                    ) -> tuple[np.ndarray, list[dict]]:
    """A crop (BGR uint8) and its labels (see :func:`parse_label`) as one training frame and its fish."""
    h, w = crop.shape[:2]
    scale = min(INPUT / w, INPUT / h, 1.0)  # as Letterbox.fit, but never enlarged
    nw, nh = max(1, min(INPUT, round(w * scale))), max(1, min(INPUT, round(h * scale)))
    box = Letterbox(nw / w, nh / h, (INPUT - nw) // 2, (INPUT - nh) // 2, (nw, nh))
    image = box.apply(crop, (INPUT, INPUT), PAD_VALUE)
    k = len(KEYPOINTS)
    fish = []
    for (cx, cy, bw, bh), points, visibility in labels:
        # fractions of the crop from its corner → the input (corner origin): u = pad + fraction · resized size
        keypoints = np.full((k, 2), np.nan)
        keypoints[:len(LABELLED)] = points * (nw, nh) + (box.pad_x, box.pad_y)
        known = np.zeros(k, bool)
        known[:len(LABELLED)] = visibility > 0
        visible = np.zeros(k, bool)
        visible[:len(LABELLED)] = visibility == 2
        u0, u1 = (cx - bw / 2) * nw + box.pad_x, (cx + bw / 2) * nw + box.pad_x
        v0, v1 = (cy - bh / 2) * nh + box.pad_y, (cy + bh / 2) * nh + box.pad_y
        length = float(np.hypot(*(keypoints[0] - keypoints[1])))
        fish.append({"keypoints": keypoints, "visible": visible, "in_frame": known.copy(), "known": known,
                     "background_known": False,
                     "box": (float(u0), float(v0), float(u1), float(v1)),
                     "required": bool(visible[0] and visible[1] and length >= MIN_REQUIRED_PX)})
    return image, fish


def read_training_set(folder: str | Path) -> TrainingSet:
    """Every crop of the training set in ``folder`` with its labels, as training frames (module docstring)."""
    folder = Path(folder)
    images_folder, labels_folder = folder / "images", folder / "labels"
    if not images_folder.is_dir():
        raise UsvipsError(f"{folder}: not a training set (no images folder; make one with `usvips project export "
                          "PROJECT OUT --format training-set`)")
    crops = sorted(p for p in images_folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not crops:
        raise UsvipsError(f"{images_folder}: no crops")
    frames, fish, names = [], [], []
    for path in crops:
        label_path = labels_folder / f"{path.stem}.txt"
        if not label_path.is_file():
            raise UsvipsError(f"{label_path}: missing (the label of {path.name})")
        try:
            text = label_path.read_text()
        except (OSError, UnicodeDecodeError) as error:
            raise UsvipsError(f"{label_path}: cannot be read ({error})") from None
        labels = [parse_label(line, f"{label_path}:{n}") for n, line in enumerate(text.splitlines(), start=1)
                  if line.strip()]
        if not labels:
            raise UsvipsError(f"{label_path}: no label line")
        crop = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if crop is None or crop.size == 0:
            raise UsvipsError(f"{path}: not an image OpenCV can read")
        image, frame = frame_from_crop(crop, labels)
        frames.append(image)
        fish.append(frame)
        names.append(path.name)
    return TrainingSet(folder, np.stack(frames), fish, names)
