"""Scene descriptions (``scene.json``) for ``usvips render``: a stereo rig, its housing, the stations of
its image pairs, the water, and what is in the scene (the calibration frame, a seafloor).

    {"format": "usvips-scene", "version": 1, "name": "rov_flatport", "seed": 1,
     "image": {"width": 640, "height": 480, "supersample": 3},
     "left": {"f": 700, "xp": 319.5, "yp": 239.5, ...}, "right": {...},          # interior, seeds' names
     "relative": {"bx": 0.4, "by": 0, "bz": 0, "omega": 0, "phi": -0.1, "kappa": 0},
     "housing": {"kind": "flat-port", "left": {"d": 0, ...}, "right": {...}},    # camera frames, metres
     "water": {"attenuation": 0.3, "backscatter": 70, "blur": 0.7, "noise": 2.0},
     "frame": {"targets": "calibration_frame.csv", "radius": 0.04},               # resources/ file
     "floor": {"z": -100.6, "cell": 0.03, "mean": 70, "contrast": 25},
     "objects": [{"kind": "fish", "label": "fish1", "snout": [X, Y, Z], "fork": [X, Y, Z], "up": [0, 1, 0]},
                 {"kind": "pipe", "label": "pipe1", "start": [...], "end": [...], "radius": 0.05},
                 {"kind": "rock", "label": "rock1", "centre": [...], "semi_axes": [0.12, 0.09, 0.06]}],
     "observation_noise_px": 0.3,
     "pairs": [{"label": "air1", "medium": "air", "contents": ["frame", "floor"],
                "pose": {"X0": ..., "Y0": ..., "Z0": ..., "omega": ..., "phi": ..., "kappa": ...}}, ...]}

An optional ``video`` renders a short stereo video of one object moving at a constant velocity (m/s)
through a pair's scene: ``{"pair": "measure1", "frames": 30, "fps": 10, "frame_offset": 3,
"object": "fish1", "velocity": [0.2, 0.05, 0.0], "supersample": 1}``. The right camera lags by
``frame_offset`` frames: right frame j shows the instant of left frame j − frame_offset, time
t = frame / fps seconds with the object at its described position at t = 0.

``image`` may also say ``"colour": true`` (RGB with red absorbed most), ``"lighting": 0.4`` (lamp falloff
towards the corners) and ``"interlace": 1.5`` (odd rows shifted, pixels). A pair's ``contents`` (default:
everything) chooses which of ``frame``, ``floor``, ``objects`` it shows; a pair may override ``colour`` and
``lighting``.

Every key is checked: an unknown or missing one is an :class:`InputFileError` naming it, and so is
impossible geometry (the frame behind a camera, a camera inside the frame).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from usvips.core.camera import EXTERIOR_PARAMETERS, Camera, Exterior
from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.housing import AirHousing, DomeCoverHousing, FlatPortHousing, Housing
from usvips.core.interior import INTERIOR_PARAMETERS, Interior
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.synth import Fish, Pipe, Rock

FORMAT = "usvips-scene"
TOP = {"format", "version", "name", "seed", "image", "left", "right", "relative", "housing", "water", "frame",
       "floor", "objects", "observation_noise_px", "pairs", "description", "video"}
VIDEO_REQUIRED = {"pair", "frames", "fps", "frame_offset", "object", "velocity"}
CONTENTS = ("frame", "floor", "objects")
OBJECT_KEYS = {
    "fish": ({"snout", "fork"}, {"up", "depth", "brightness", "colour"}),
    "pipe": ({"start", "end"}, {"radius", "ring_spacing", "ring_width", "brightness", "colour"}),
    "rock": ({"centre"}, {"semi_axes", "brightness", "seed", "colour"}),
}
OBJECT_TYPES = {"fish": Fish, "pipe": Pipe, "rock": Rock}
HOUSINGS = {"air": AirHousing, "dome-cover": DomeCoverHousing, "flat-port": FlatPortHousing}


@dataclass(frozen=True)
class Scene:
    path: Path
    data: dict

    @property
    def name(self) -> str:
        return self.data["name"]

    @property
    def seed(self) -> int:
        return int(self.data.get("seed", 0))

    def objects(self) -> list[tuple[str, str, Fish | Pipe | Rock]]:
        """(label, kind, object) for every object in the scene."""
        result = []
        for entry in self.data.get("objects", []):
            parameters = {k: (tuple(v) if isinstance(v, list) else v) for k, v in entry.items()
                          if k not in ("kind", "label")}
            result.append((entry["label"], entry["kind"], OBJECT_TYPES[entry["kind"]](**parameters)))
        return result

    @staticmethod
    def contents(pair: dict) -> tuple[str, ...]:
        return tuple(pair.get("contents", CONTENTS))

    def rig(self, pair: dict) -> StereoRig:
        """The rig at a pair's pose, with the scene's housing underwater and none in air."""
        width, height = self.data["image"]["width"], self.data["image"]["height"]
        kind = self.data["housing"]["kind"] if pair.get("medium", "water") == "water" else "air"
        housings = [self._housing(kind, side) for side in ("left", "right")]
        pose = Exterior(**pair["pose"])
        left = Camera(Interior(**self.data["left"]), pose, housings[0], width, height)
        right = Camera(Interior(**self.data["right"]), pose, housings[1], width, height)
        return StereoRig.from_relative(left, right, RelativeOrientation(**self.data["relative"]))

    def _housing(self, kind: str, side: str) -> Housing:
        if kind == "air":
            return AirHousing()
        return HOUSINGS[kind](**self.data["housing"][side])


def _keys(path: Path, where: str, value: object, required: set[str], allowed: set[str]) -> dict:
    if not isinstance(value, dict):
        raise InputFileError(str(path), f"{where}: expected an object")
    unknown = sorted(set(value) - allowed)
    if unknown:
        raise InputFileError(str(path), f"{where}: unknown key {unknown[0]!r}")
    missing = sorted(required - set(value))
    if missing:
        raise InputFileError(str(path), f"{where}: missing key {missing[0]!r}")
    return value


def read_scene(path: str | Path) -> Scene:
    path = Path(path)
    if not path.is_file():
        raise InputFileError(str(path), "no such scene description")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise InputFileError(str(path), f"not valid JSON: {error.msg}", error.lineno) from None
    _keys(path, "scene", data, {"format", "version", "name", "image", "left", "right", "relative", "housing",
                                "pairs"}, TOP)
    if data["format"] != FORMAT or data["version"] != 1:
        raise InputFileError(str(path), f"not a version-1 USVIPS scene (format must be {FORMAT!r})")
    _keys(path, "image", data["image"], {"width", "height"},
          {"width", "height", "supersample", "colour", "lighting", "interlace"})
    for side in ("left", "right"):
        _keys(path, side, data[side], {"f", "xp", "yp"}, set(INTERIOR_PARAMETERS))
    _keys(path, "relative", data["relative"], {"bx"}, {"bx", "by", "bz", "omega", "phi", "kappa"})
    housing = _keys(path, "housing", data["housing"], {"kind"}, {"kind", "left", "right"})
    if housing["kind"] not in HOUSINGS:
        raise InputFileError(str(path), f"housing.kind: must be one of {', '.join(HOUSINGS)}")
    if "water" in data:
        _keys(path, "water", data["water"], set(), {"attenuation", "backscatter", "blur", "noise"})
    if "frame" in data:
        _keys(path, "frame", data["frame"], {"targets"}, {"targets", "radius"})
    if "floor" in data:
        _keys(path, "floor", data["floor"], {"z"}, {"z", "cell", "mean", "contrast", "seed"})
    objects = data.get("objects", [])
    if not isinstance(objects, list):
        raise InputFileError(str(path), "objects: expected a list")
    labels = set()
    for i, entry in enumerate(objects):
        kind = entry.get("kind") if isinstance(entry, dict) else None
        if kind not in OBJECT_KEYS:
            raise InputFileError(str(path), f"objects[{i}].kind: must be one of {', '.join(OBJECT_KEYS)}")
        required, optional = OBJECT_KEYS[kind]
        _keys(path, f"objects[{i}]", entry, required | {"kind", "label"}, required | optional | {"kind", "label"})
        if entry["label"] in labels:
            raise InputFileError(str(path), f"objects[{i}].label: {entry['label']!r} is used twice")
        labels.add(entry["label"])
    if not isinstance(data["pairs"], list) or not data["pairs"]:
        raise InputFileError(str(path), "pairs: at least one pair is needed")
    scene = Scene(path, data)
    try:
        scene.objects()
    except (UsvipsError, TypeError, ValueError) as error:
        raise InputFileError(str(path), f"objects: {error}") from None
    for i, pair in enumerate(data["pairs"]):
        _keys(path, f"pairs[{i}]", pair, {"label", "pose"},
              {"label", "medium", "pose", "contents", "colour", "lighting"})
        unknown = [c for c in pair.get("contents", CONTENTS) if c not in CONTENTS]
        if unknown:
            raise InputFileError(str(path), f"pairs[{i}].contents: unknown {unknown[0]!r} (use {', '.join(CONTENTS)})")
        _keys(path, f"pairs[{i}].pose", pair["pose"], set(EXTERIOR_PARAMETERS), set(EXTERIOR_PARAMETERS))
        if pair.get("medium", "water") not in ("air", "water"):
            raise InputFileError(str(path), f"pairs[{i}].medium: must be 'air' or 'water'")
        try:
            scene.rig(pair)
        except UsvipsError as error:
            raise InputFileError(str(path), f"pairs[{i}]: {error}") from None
    if "video" in data:
        _check_video(path, data["video"], data["pairs"], labels)
    return scene


def _whole(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _check_video(path: Path, video: object, pairs: list, objects: set[str]) -> None:
    _keys(path, "video", video, VIDEO_REQUIRED, VIDEO_REQUIRED | {"supersample"})
    pair = next((p for p in pairs if p["label"] == video["pair"]), None)
    if pair is None:
        raise InputFileError(str(path), f"video.pair: no pair labelled {video['pair']!r}")
    if "objects" not in pair.get("contents", CONTENTS):
        raise InputFileError(str(path), f"video.pair: pair {video['pair']!r} does not show the objects")
    if video["object"] not in objects:
        raise InputFileError(str(path), f"video.object: no object labelled {video['object']!r}")
    if not _whole(video["frames"]) or not 2 <= video["frames"] <= 1000:
        raise InputFileError(str(path), f"video.frames: must be a whole number from 2 to 1000, got {video['frames']!r}")
    if not _whole(video["fps"]) or video["fps"] <= 0:
        raise InputFileError(str(path), f"video.fps: must be a positive whole number, got {video['fps']!r}")
    if not _whole(video["frame_offset"]) or abs(video["frame_offset"]) >= video["frames"]:
        raise InputFileError(str(path), "video.frame_offset: must be a whole number of frames, smaller in size "
                             f"than video.frames, got {video['frame_offset']!r}")
    velocity = video["velocity"]
    if (not isinstance(velocity, list) or len(velocity) != 3
            or not all(isinstance(v, int | float) and not isinstance(v, bool) and abs(v) < 1e6 for v in velocity)):
        raise InputFileError(str(path), "video.velocity: must be three numbers (m/s)")
    if "supersample" in video and (not _whole(video["supersample"]) or not 1 <= video["supersample"] <= 4):
        raise InputFileError(str(path), "video.supersample: must be 1, 2, 3 or 4")
