"""Projects with fish of known truth for the detection service and command: a calibrated flat-port rig,
an image pair (or a short video) whose left image is dark and right image bright, and a model that gives
each fish's true keypoint pixels — the left ones on a dark image, the right ones on a bright one. The model
is either a deterministic fake :class:`~usvips.core.detection.Detector` (:func:`fake_model`) or a tiny ONNX
network that switches between two output tables on its input's mean (:func:`write_switching_model`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from tests.core.calibration_scenes import FLAT, HEIGHT, WIDTH, rig_at
from tests.core.detection.yolo_tables import row
from usvips.app.detection_model import DetectionModel
from usvips.core.detection import Detection, Keypoint, Letterbox, ModelDescription
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_file import calibration_to_dict
from usvips.store import Project

DARK, BRIGHT = 40, 200
NAMES = ("snout", "fork")


@dataclass
class Scene:
    """True snout and fork (n, 2, 3) m in the pair's rig frame and their pixels (n, 2, 2) in each image."""

    fish: np.ndarray
    left: np.ndarray
    right: np.ndarray

    @property
    def lengths(self) -> np.ndarray:
        return np.linalg.norm(self.fish[:, 1] - self.fish[:, 0], axis=1)


def calibration() -> StereoCalibration:
    rig = rig_at(0, FLAT)
    return StereoCalibration.from_cameras(rig.left, rig.right, "water", 0.3, station="s1")


def scene(seed: int = 0, count: int = 3) -> Scene:
    """``count`` fish 1.5-2.5 m from the rig, 0.3-0.5 m long, well apart, wholly inside both images."""
    cal = calibration()
    rig = cal.rig(0, "rig")
    rng = np.random.default_rng(seed)
    fish, lefts, rights = [], [], []
    while len(fish) < count:
        start = np.array([rng.uniform(600, WIDTH - 60), rng.uniform(100, HEIGHT - 100)])
        bundle = rig.left.rays(start[None])
        snout = bundle.origins[0] + rng.uniform(1.5, 2.5) * bundle.directions[0]
        heading = np.array([-1.0, rng.uniform(-0.3, 0.3), rng.uniform(-0.2, 0.2)])
        body = np.vstack([snout, snout + rng.uniform(0.3, 0.5) * heading / np.linalg.norm(heading)])
        left, right = rig.left.project(body), rig.right.project(body)
        inside = all(p.ok.all() and np.all((p.pixels > 30) & (p.pixels < np.array([WIDTH, HEIGHT]) - 30))
                     for p in (left, right))
        apart = all(np.linalg.norm(left.pixels.mean(axis=0) - other.mean(axis=0)) > 150 for other in lefts)
        if inside and apart:
            fish.append(body)
            lefts.append(left.pixels)
            rights.append(right.pixels)
    return Scene(np.array(fish), np.array(lefts), np.array(rights))


def detections(pixels: np.ndarray) -> tuple[Detection, ...]:
    out = []
    for points in pixels:
        x0, y0 = points.min(axis=0) - 20
        x1, y1 = points.max(axis=0) + 20
        out.append(Detection((x0, y0, x1, y1), "fish", 0.9,
                             tuple(Keypoint(n, float(x), float(y), 0.95) for n, (x, y) in zip(NAMES, points,
                                                                                              strict=True))))
    return tuple(out)


class FakeDetector:
    """Gives the scene's left detections on a dark image and its right ones on a bright image."""

    def __init__(self, truth: Scene) -> None:
        self.truth = truth

    def detect(self, image: np.ndarray) -> tuple[Detection, ...]:
        return detections(self.truth.left if float(np.mean(image)) < (DARK + BRIGHT) / 2 else self.truth.right)


def description(sigma: float | None = 1.0, model: str = "fake.onnx") -> ModelDescription:
    sigmas = () if sigma is None else tuple((n, sigma) for n in NAMES)
    return ModelDescription(model, "yolo-pose", 320, 320, ("fish",), NAMES, keypoint_sigma_px=sigmas,
                            keypoint_sigma_basis="test scenes" if sigma is not None else "")


def fake_model(truth: Scene, sigma: float | None = 1.0) -> DetectionModel:
    return DetectionModel("fake-fish", "ab" * 32, description(sigma), lambda: FakeDetector(truth))


def write_images(folder: Path, size=(WIDTH, HEIGHT)) -> tuple[Path, Path]:
    left, right = folder / "left.png", folder / "right.png"
    cv2.imwrite(str(left), np.full((size[1], size[0], 3), DARK, np.uint8))
    cv2.imwrite(str(right), np.full((size[1], size[0], 3), BRIGHT, np.uint8))
    return left, right


def make_project(folder: Path, label: str = "dive") -> Path:
    """A project with image pair ``label`` (dark left, bright right) and the calibration active for it."""
    left, right = write_images(folder)
    path = folder / "survey.usvips"
    with Project.create(path) as project:
        project.add_pair(label, left, right, size=(WIDTH, HEIGHT))
        project.add_calibration("cal", calibration_to_dict(calibration()), (label,))
    return path


def switching_model(dark: np.ndarray, bright: np.ndarray, width: int, height: int) -> bytes:
    """An ONNX model whose output is ``dark`` when its input's mean is below 0.5 (after 1/255 scaling) and
    ``bright`` above (a step made of Sub, Mul and Clip, which OpenCV's DNN module runs)."""
    from onnx import TensorProto, helper, numpy_helper

    dark, bright = np.asarray(dark, np.float32), np.asarray(bright, np.float32)
    nodes = [helper.make_node("ReduceMean", ["images"], ["mean"], keepdims=0),
             helper.make_node("Sub", ["mean", "half"], ["centred"]),
             helper.make_node("Mul", ["centred", "steep"], ["steeped"]),
             helper.make_node("Clip", ["steeped", "zero", "one"], ["weight"]),
             helper.make_node("Mul", ["difference", "weight"], ["change"]),
             helper.make_node("Add", ["dark", "change"], ["output0"])]
    constants = {"half": np.array(0.5, np.float32), "steep": np.array(1000.0, np.float32),
                 "zero": np.array(0.0, np.float32), "one": np.array(1.0, np.float32), "dark": dark,
                 "difference": bright - dark}
    graph = helper.make_graph(
        nodes, "switching-yolo-pose",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, height, width])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, list(dark.shape))],
        [numpy_helper.from_array(v, k) for k, v in constants.items()])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    return model.SerializeToString()


def model_table(pixels: np.ndarray, width: int, height: int, image=(WIDTH, HEIGHT)) -> np.ndarray:
    letterbox = Letterbox.fit(image, (width, height))
    rows = []
    for points in pixels:
        box = np.concatenate([points.min(axis=0) - 20, points.max(axis=0) + 20])
        rows.append(row(box, 0, 0.9, np.column_stack([points, [0.95, 0.95]]), letterbox, 1))
    return np.array(rows).T[None]


def write_switching_model(folder: Path, truth: Scene, sigma: float | None = 1.0, name: str = "fish") -> Path:
    """The description file (``name``.toml) and ONNX model of a network that gives ``truth``'s keypoints."""
    size = 320
    (folder / f"{name}.onnx").write_bytes(switching_model(model_table(truth.left, size, size),
                                                          model_table(truth.right, size, size), size, size))
    sigma_table = "" if sigma is None else (f'\n[keypoint_sigma]\nbasis = "test scenes"\n'
                                            f"px = {{snout = {sigma}, fork = {sigma}}}\n")
    path = folder / f"{name}.toml"
    path.write_text(f'[model]\nfile = "{name}.onnx"\nfamily = "yolo-pose"\ninput_width = {size}\n'
                    f'input_height = {size}\n\n[output]\nclasses = ["fish"]\nkeypoints = ["snout", "fork"]\n'
                    + sigma_table)
    return path


def add_video(folder: Path, project, label: str = "drop", frames: int = 6, size=(WIDTH, HEIGHT)) -> None:
    """A stereo video ``label`` of ``frames`` frames (lossless): every left frame dark, every right one
    bright, synchronised (offset 0)."""
    from usvips.app.video_project import add_video as store_video
    from usvips.io.video_writer import encode_video

    for side, value in (("left", DARK), ("right", BRIGHT)):
        encode_video(folder / f"{label}_{side}.mkv", [np.full((size[1], size[0], 3), value, np.uint8)] * frames,
                     25.0, "ffv1")
    store_video(project, [folder / f"{label}_left.mkv"], [folder / f"{label}_right.mkv"], label)


def make_video_project(folder: Path, label: str = "drop", frames: int = 6) -> Path:
    """:func:`make_project` with the stereo video ``label`` (:func:`add_video`) and a calibration active for it."""
    path = make_project(folder)
    with Project.open(path) as project:
        add_video(folder, project, label, frames=frames)
        project.add_calibration("cal", calibration_to_dict(calibration()), (label,))
    return path
