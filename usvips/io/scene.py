"""Scene descriptions (``scene.json``) for ``usvips render``: a stereo rig, its housing, the stations of
its image pairs, the water, and what is in the scene (the calibration frame, a seafloor).

    {"format": "usvips-scene", "version": 1, "name": "rov_flatport", "seed": 1,
     "image": {"width": 640, "height": 480, "supersample": 3},
     "left": {"f": 700, "xp": 319.5, "yp": 239.5, ...}, "right": {...},          # interior, seeds' names
     "relative": {"bx": 0.4, "by": 0, "bz": 0, "omega": 0, "phi": -0.1, "kappa": 0},
     "housing": {"kind": "flat-port", "left": {"d": 0, ...}, "right": {...},     # a registered kind's values
                 "known": {"t": 0.016, "n2": 1.65}},       # optional: what its calibration may take as known
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
import math
import re
from dataclasses import dataclass
from pathlib import Path

from usvips.core import housing as housings
from usvips.core.camera import EXTERIOR_PARAMETERS, Camera, Exterior
from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.housing import AirHousing, Housing
from usvips.core.interior import INTERIOR_PARAMETERS, Interior
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.synth import Fish, Pipe, Rock
from usvips.io.json_text import loads_strict
from usvips.io.manifest import housing_known_values

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
        underwater = pair.get("medium", "water") == "water"
        cameras = [self.housing(side) if underwater else AirHousing() for side in ("left", "right")]
        pose = Exterior(**pair["pose"])
        left = Camera(Interior(**self.data["left"]), pose, cameras[0], width, height)
        right = Camera(Interior(**self.data["right"]), pose, cameras[1], width, height)
        return StereoRig.from_relative(left, right, RelativeOrientation(**self.data["relative"]))

    @property
    def housing_known(self) -> dict[str, tuple[float, float | None]]:
        """The housing values a user of this rig knows beforehand (``housing.known``): name → (value, sigma
        or None for fixed), for its calibration and its sample's manifest."""
        return housing_known_values(self.path, self.data["housing"]["kind"], self.data["housing"].get("known"),
                                    "housing.known")

    def housing(self, side: str) -> Housing:
        """The scene's housing of one camera (``left``/``right``), built by its registered kind."""
        return _housing(self.data["housing"], side)


def _housing(housing: dict, side: str) -> Housing:
    cls = housings.kind(housing["kind"])
    return cls.from_values(housing.get(side, {}) if cls.field_names() else {})


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


#: A plain name that is safe as part of a file name (pair labels become image file names).
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")
#: Largest image side (pixels) and largest JSON file (bytes) a scene may ask for.
MAX_SIDE = 16384
MAX_FILE_BYTES = 4 << 20
#: Largest rendering (pixels × supersample²) a scene may ask for: about 1.5 GB of float64 work arrays.
MAX_SAMPLES = 64_000_000


@dataclass(frozen=True)
class Rule:
    """What one value of a scene must be: ``kind`` is ``int``, ``number``, ``bool``, ``text``, ``name``
    (a :data:`SAFE_NAME`), ``csv`` (a plain ``.csv`` file name) or ``point`` (three numbers); numbers lie in
    ``[low, high]`` (``low_open``: strictly above ``low``)."""

    kind: str
    low: float = -1e6
    high: float = 1e6
    low_open: bool = False

    def problem(self, value: object) -> str | None:
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if self.kind == "bool":
            return None if isinstance(value, bool) else "must be true or false"
        if self.kind == "text":
            return None if isinstance(value, str) else "must be a string"
        if self.kind == "name":
            return None if isinstance(value, str) and SAFE_NAME.fullmatch(value) else (
                "must be a plain name of letters, digits, '.', '_' or '-' (at most 64, no path)")
        if self.kind == "csv":
            return None if isinstance(value, str) and SAFE_NAME.fullmatch(value) and value.endswith(".csv") else (
                "must be a plain .csv file name beside the scene or in resources/ (no folder, no '..')")
        if self.kind == "point":
            if not (isinstance(value, list) and len(value) == 3 and all(
                    isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and abs(v) <= 1e6
                    for v in value)):
                return "must be three finite numbers (metres)"
            return None
        if self.kind == "int" and not (number and float(value).is_integer() and isinstance(value, int)):
            return f"must be a whole number, got {_show(value)}"
        if not number or not math.isfinite(value):
            return f"must be a finite number, got {_show(value)}"
        if value < self.low or (self.low_open and value == self.low) or value > self.high:
            left = "(" if self.low_open else "["
            return f"must be in {left}{self.low:g}, {self.high:g}], got {_show(value)}"
        return None


def _show(value: object) -> str:
    text = json.dumps(value) if isinstance(value, int | float | bool | str | None) else type(value).__name__
    return text if len(text) <= 24 else text[:23] + "…"


#: The scene format as one table: "section.key" → rule ("*" = every key of that object).
RULES: dict[str, Rule] = {
    "name": Rule("name"), "description": Rule("text"), "seed": Rule("int", 0, 2**31 - 1),
    "observation_noise_px": Rule("number", 0, 100),
    "image.width": Rule("int", 8, MAX_SIDE), "image.height": Rule("int", 8, MAX_SIDE),
    "image.supersample": Rule("int", 1, 8), "image.colour": Rule("bool"), "image.lighting": Rule("number", 0, 1),
    "image.interlace": Rule("number", -100, 100),
    "left.*": Rule("number"), "right.*": Rule("number"),
    "left.f": Rule("number", 0, 1e6, True), "right.f": Rule("number", 0, 1e6, True),
    "left.sy": Rule("number", 0, 10, True), "right.sy": Rule("number", 0, 10, True),
    "relative.*": Rule("number", -1e4, 1e4),
    "housing.kind": Rule("text"), "housing.left.*": Rule("number"), "housing.right.*": Rule("number"),
    "water.attenuation": Rule("number", 0, 100), "water.backscatter": Rule("number", 0, 255),
    "water.blur": Rule("number", 0, 50), "water.noise": Rule("number", 0, 255),
    "frame.targets": Rule("csv"), "frame.radius": Rule("number", 0, 10, True),
    "floor.z": Rule("number"), "floor.cell": Rule("number", 1e-4, 1e3), "floor.mean": Rule("number", 0, 255),
    "floor.contrast": Rule("number", 0, 255), "floor.seed": Rule("int", 0, 2**31 - 1),
    "objects.label": Rule("text"), "objects.kind": Rule("text"), "objects.snout": Rule("point"),
    "objects.fork": Rule("point"), "objects.up": Rule("point"), "objects.start": Rule("point"),
    "objects.end": Rule("point"), "objects.centre": Rule("point"), "objects.semi_axes": Rule("point"),
    "objects.colour": Rule("point"), "objects.depth": Rule("number", 0, 100),
    "objects.brightness": Rule("number", 0, 255), "objects.radius": Rule("number", 0, 100, True),
    "objects.ring_spacing": Rule("number", 0, 100, True), "objects.ring_width": Rule("number", 0, 100),
    "objects.seed": Rule("int", 0, 2**31 - 1),
    "pairs.label": Rule("name"), "pairs.medium": Rule("text"), "pairs.colour": Rule("bool"),
    "pairs.lighting": Rule("number", 0, 1), "pairs.pose.*": Rule("number", -1e4, 1e4),
}


def _check_values(path: Path, where: str, section: str, value: dict) -> None:
    """Apply :data:`RULES` to the keys of one object of the scene (``section`` is its table prefix)."""
    for key, item in value.items():
        rule = RULES.get(f"{section}.{key}" if section else key) or RULES.get(f"{section}.*")
        if rule is None:
            continue
        problem = rule.problem(item)
        if problem:
            raise InputFileError(str(path), f"{where}{'.' if where else ''}{key}: {problem}")


def read_scene(path: str | Path) -> Scene:
    """Read and check a scene description; any problem is an :class:`InputFileError` naming the key."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(str(path), "no such scene description")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise InputFileError(str(path), f"too large for a scene description (over {MAX_FILE_BYTES >> 20} MiB)")
    try:
        data = loads_strict(path.read_text(encoding="utf-8-sig"), path)
    except json.JSONDecodeError as error:
        raise InputFileError(str(path), f"not valid JSON: {error.msg}", error.lineno) from None
    except UnicodeDecodeError:
        raise InputFileError(str(path), "not a text (UTF-8) file") from None
    except RecursionError:
        raise InputFileError(str(path), "nested too deeply to be a scene description") from None
    _keys(path, "scene", data, {"format", "version", "name", "image", "left", "right", "relative", "housing",
                                "pairs"}, TOP)
    if data["format"] != FORMAT or data["version"] != 1 or isinstance(data["version"], bool):
        raise InputFileError(str(path), f"not a version-1 USVIPS scene (format must be {FORMAT!r}, version 1)")
    _check_values(path, "", "", data)
    _keys(path, "image", data["image"], {"width", "height"},
          {"width", "height", "supersample", "colour", "lighting", "interlace"})
    _check_values(path, "image", "image", data["image"])
    image = data["image"]
    samples = image["width"] * image["height"] * image.get("supersample", 3) ** 2
    if samples > MAX_SAMPLES:
        raise InputFileError(str(path), f"image: width × height × supersample² is {samples:,} samples, more than "
                             f"{MAX_SAMPLES:,}; make the image or the supersampling smaller")
    for side in ("left", "right"):
        _keys(path, side, data[side], {"f", "xp", "yp"}, set(INTERIOR_PARAMETERS))
        _check_values(path, side, side, data[side])
    _keys(path, "relative", data["relative"], {"bx"}, {"bx", "by", "bz", "omega", "phi", "kappa"})
    _check_values(path, "relative", "relative", data["relative"])
    if not any(data["relative"].get(key, 0) for key in ("bx", "by", "bz")):
        raise InputFileError(str(path), "relative: bx, by and bz are all 0: the two cameras are in one place, a "
                             "stereo rig needs a baseline (metres)")
    housing = _keys(path, "housing", data["housing"], {"kind"}, {"kind", "left", "right", "known"})
    if not isinstance(housing["kind"], str) or housing["kind"] not in housings.names():
        raise InputFileError(str(path), f"housing.kind: must be one of {', '.join(housings.names())}")
    if housings.kind(housing["kind"]).field_names():
        for side in ("left", "right"):
            _keys(path, f"housing.{side}", housing.get(side), set(), set(housing.get(side) or ()))
            _check_values(path, f"housing.{side}", f"housing.{side}", housing[side])
            try:
                _housing(housing, side)
            except UsvipsError as error:
                raise InputFileError(str(path), f"housing.{side}: {error}") from None
    housing_known_values(path, housing["kind"], housing.get("known"), "housing.known")
    if "water" in data:
        _keys(path, "water", data["water"], set(), {"attenuation", "backscatter", "blur", "noise"})
        _check_values(path, "water", "water", data["water"])
    if "frame" in data:
        _keys(path, "frame", data["frame"], {"targets"}, {"targets", "radius"})
        _check_values(path, "frame", "frame", data["frame"])
    if "floor" in data:
        _keys(path, "floor", data["floor"], {"z"}, {"z", "cell", "mean", "contrast", "seed"})
        _check_values(path, "floor", "floor", data["floor"])
    objects = data.get("objects", [])
    if not isinstance(objects, list):
        raise InputFileError(str(path), "objects: expected a list")
    labels = set()
    for i, entry in enumerate(objects):
        kind = entry.get("kind") if isinstance(entry, dict) else None
        if not isinstance(kind, str) or kind not in OBJECT_KEYS:
            raise InputFileError(str(path), f"objects[{i}].kind: must be one of {', '.join(OBJECT_KEYS)}")
        required, optional = OBJECT_KEYS[kind]
        _keys(path, f"objects[{i}]", entry, required | {"kind", "label"}, required | optional | {"kind", "label"})
        _check_values(path, f"objects[{i}]", "objects", entry)
        if entry["label"] in labels:
            raise InputFileError(str(path), f"objects[{i}].label: {entry['label']!r} is used twice")
        labels.add(entry["label"])
    if not isinstance(data["pairs"], list) or not data["pairs"]:
        raise InputFileError(str(path), "pairs: at least one pair is needed")
    pair_labels: set[str] = set()
    scene = Scene(path, data)
    try:
        scene.objects()
    except (UsvipsError, TypeError, ValueError) as error:
        raise InputFileError(str(path), f"objects: {error}") from None
    for i, pair in enumerate(data["pairs"]):
        _keys(path, f"pairs[{i}]", pair, {"label", "pose"},
              {"label", "medium", "pose", "contents", "colour", "lighting"})
        _check_values(path, f"pairs[{i}]", "pairs", pair)
        if pair["label"] in pair_labels:
            raise InputFileError(str(path), f"pairs[{i}].label: {pair['label']!r} is used twice")
        pair_labels.add(pair["label"])
        contents = pair.get("contents", list(CONTENTS))
        if not isinstance(contents, list) or not all(isinstance(c, str) for c in contents):
            raise InputFileError(str(path), f"pairs[{i}].contents: must be a list of names ({', '.join(CONTENTS)})")
        unknown = [c for c in pair.get("contents", CONTENTS) if c not in CONTENTS]
        if unknown:
            raise InputFileError(str(path), f"pairs[{i}].contents: unknown {unknown[0]!r} (use {', '.join(CONTENTS)})")
        _keys(path, f"pairs[{i}].pose", pair["pose"], set(EXTERIOR_PARAMETERS), set(EXTERIOR_PARAMETERS))
        _check_values(path, f"pairs[{i}].pose", "pairs.pose", pair["pose"])
        if pair.get("medium", "water") not in ("air", "water"):
            raise InputFileError(str(path), f"pairs[{i}].medium: must be 'air' or 'water'")
        try:
            scene.rig(pair)
        except (UsvipsError, TypeError, ValueError) as error:
            raise InputFileError(str(path), f"pairs[{i}]: {error}") from None
    if "video" in data:
        _check_video(path, data["video"], data["pairs"], labels)
    return scene


def _whole(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _check_video(path: Path, video: object, pairs: list, objects: set[str]) -> None:
    _keys(path, "video", video, VIDEO_REQUIRED, VIDEO_REQUIRED | {"supersample"})
    if not isinstance(video["pair"], str) or not isinstance(video["object"], str):
        raise InputFileError(str(path), "video.pair and video.object: must be labels (strings)")
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
