"""Sample-project manifests (``project.json``): what a self-describing project directory holds.

A manifest names, relative to its own directory: the control file, the stereo image pairs, the
observation files and their role, calibration files and which pairs they serve, an optional stereo
video and an optional truth file (synthetic samples). The store imports a manifest into a project
database; nothing else in a sample directory is needed to open it.

    {"format": "usvips-sample", "version": 1, "name": "...", "description": "...",
     "control": "control.csv", "housing": "dome-cover",
     "housing_known": {"t": 0.016, "n2": [1.65, 0.01]},    # optional: value (fixed) or [value, sigma]
     "pairs": [{"label": "air1", "left": "images/air1_left.png", "right": "images/air1_right.png",
                "medium": "air"}],
     "observations": [{"file": "obs.csv", "role": "calibration-air", "pairs": ["air1"]}],
     "calibrations": [{"file": "cal.json", "active_for": ["w1"]}],
     "video": {"left": "video_left.avi", "right": "video_right.avi", "frame_offset": 3},
     "truth": "truth.json"}

``housing_known`` holds housing values known beforehand (a manufacturer's glass thickness, an index),
by the housing kind's parameter symbols or its calibration names (``g_l``); a number holds the parameter
fixed, ``[value, sigma]`` makes it a prior. Names are checked against the kind (the registry).

Roles: ``calibration-air``, ``calibration-water``, ``check``, ``measurement``. ``medium``: ``air`` or
``water``. Every path must stay inside the directory.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from usvips.core import housing as housings
from usvips.core.errors import InputFileError, UsvipsError

FORMAT = "usvips-sample"
VERSION = 1
ROLES = ("calibration-air", "calibration-water", "check", "measurement")
MEDIA = ("air", "water")
_TOP_KEYS = {"format", "version", "name", "description", "control", "housing", "housing_known", "pairs", "observations",
             "calibrations", "video", "truth"}
#: Largest manifest read (bytes).
MAX_FILE_BYTES = 4 << 20


@dataclass(frozen=True)
class ImagePairEntry:
    label: str
    left: Path | None
    right: Path | None
    medium: str = "water"


@dataclass(frozen=True)
class ObservationEntry:
    file: Path
    role: str
    pairs: tuple[str, ...] = ()


@dataclass(frozen=True)
class CalibrationEntry:
    file: Path
    active_for: tuple[str, ...] = ()


@dataclass(frozen=True)
class VideoEntry:
    left: Path
    right: Path
    frame_offset: int = 0


@dataclass(frozen=True)
class Manifest:
    """A parsed ``project.json``; every path is absolute."""

    path: Path
    name: str
    description: str = ""
    control: Path | None = None
    pairs: tuple[ImagePairEntry, ...] = ()
    observations: tuple[ObservationEntry, ...] = ()
    calibrations: tuple[CalibrationEntry, ...] = ()
    video: VideoEntry | None = None
    truth: Path | None = None
    housing: str | None = None
    #: name → (value, sigma or None for fixed): the housing values known beforehand (``housing_known``).
    housing_known: dict[str, tuple[float, float | None]] = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @property
    def directory(self) -> Path:
        return self.path.parent


def _inside(manifest: Path, key: str, value: object, must_exist: bool = True) -> Path:
    if not isinstance(value, str) or not value:
        raise InputFileError(str(manifest), f"key {key!r}: expected a relative file path")
    if "\x00" in value or len(value) > 1024:
        raise InputFileError(str(manifest), f"key {key!r}: not a usable file path")
    base = manifest.parent.resolve()
    try:
        target = (base / value).resolve()
    except (OSError, RuntimeError):
        raise InputFileError(str(manifest), f"key {key!r}: not a usable file path") from None
    if base != target and base not in target.parents:
        raise InputFileError(str(manifest), f"key {key!r}: {value[:80]!r} points outside the project directory")
    if must_exist and not target.is_file():
        raise InputFileError(str(manifest), f"key {key!r}: file {value[:80]!r} does not exist")
    return target


def _labels(manifest: Path, where: str, value: object, known: set[str]) -> tuple[str, ...]:
    """A list of pair labels, each one of the manifest's pairs."""
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputFileError(str(manifest), f"{where}: expected a list of pair labels")
    unknown = [v for v in value if v not in known]
    if unknown:
        raise InputFileError(str(manifest), f"{where}: no pair labelled {unknown[0][:40]!r}")
    return tuple(value)


def _entries(manifest: Path, data: dict, key: str) -> list[dict]:
    value = data.get(key, [])
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise InputFileError(str(manifest), f"key {key!r}: expected a list of objects")
    return value


def _unknown(manifest: Path, where: str, entry: dict, allowed: set[str]) -> None:
    unknown = sorted(set(entry) - allowed)
    if unknown:
        raise InputFileError(str(manifest), f"{where}: unknown key(s) {', '.join(map(repr, unknown))}")


def read_manifest(path: str | Path) -> Manifest:
    """Read and validate a manifest (``project.json`` or the directory holding one)."""
    path = Path(path)
    if path.is_dir():
        path = path / "project.json"
    if not path.is_file():
        raise InputFileError(str(path), "no such project manifest")
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise InputFileError(str(path), f"too large for a manifest (over {MAX_FILE_BYTES >> 20} MiB)")
        data = json.loads(path.read_text(encoding="utf-8-sig"))
    except json.JSONDecodeError as error:
        raise InputFileError(str(path), f"not valid JSON: {error.msg}", error.lineno) from None
    except UnicodeDecodeError:
        raise InputFileError(str(path), "not a text (UTF-8) file") from None
    except RecursionError:
        raise InputFileError(str(path), "nested too deeply to be a manifest") from None
    except OSError as error:
        raise InputFileError(str(path), f"cannot read the file: {error.strerror or error}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputFileError(str(path), f"not a USVIPS sample manifest (\"format\" must be {FORMAT!r})")
    if data.get("version") != VERSION:
        raise InputFileError(str(path), f"manifest version {data.get('version')!r} is not supported "
                             f"(this USVIPS reads version {VERSION})")
    _unknown(path, "manifest", data, _TOP_KEYS)
    if not isinstance(data.get("name"), str) or not data["name"]:
        raise InputFileError(str(path), "key 'name': a non-empty name is required")
    if not isinstance(data.get("description", ""), str):
        raise InputFileError(str(path), "key 'description': must be a string")
    pairs = []
    for entry in _entries(path, data, "pairs"):
        _unknown(path, "pairs entry", entry, {"label", "left", "right", "medium"})
        label = entry.get("label")
        if not isinstance(label, str) or not label:
            raise InputFileError(str(path), "pairs entry: 'label' is required")
        medium = entry.get("medium", "water")
        if not isinstance(medium, str) or medium not in MEDIA:
            raise InputFileError(str(path), f"pair {label!r}: medium must be one of {MEDIA}, got {medium!r}")
        left = _inside(path, f"pairs[{label}].left", entry["left"]) if entry.get("left") else None
        right = _inside(path, f"pairs[{label}].right", entry["right"]) if entry.get("right") else None
        pairs.append(ImagePairEntry(label, left, right, medium))
    labels = [p.label for p in pairs]
    if len(set(labels)) != len(labels):
        raise InputFileError(str(path), "pairs: duplicate pair label")
    observations = []
    for entry in _entries(path, data, "observations"):
        _unknown(path, "observations entry", entry, {"file", "role", "pairs"})
        role = entry.get("role")
        if not isinstance(role, str) or role not in ROLES:
            raise InputFileError(str(path), f"observations entry: role must be one of {ROLES}")
        observations.append(ObservationEntry(_inside(path, "observations.file", entry.get("file")), role,
                                             _labels(path, "observations.pairs", entry.get("pairs", []),
                                                     set(labels))))
    calibrations = []
    for entry in _entries(path, data, "calibrations"):
        _unknown(path, "calibrations entry", entry, {"file", "active_for"})
        calibrations.append(CalibrationEntry(_inside(path, "calibrations.file", entry.get("file")),
                                             _labels(path, "calibrations.active_for", entry.get("active_for", []),
                                                     set(labels))))
    video = None
    if data.get("video") is not None:
        v = data["video"]
        if not isinstance(v, dict):
            raise InputFileError(str(path), "key 'video': expected an object")
        _unknown(path, "video", v, {"left", "right", "frame_offset"})
        offset = v.get("frame_offset", 0)
        if not isinstance(offset, int) or isinstance(offset, bool):
            raise InputFileError(str(path), f"video.frame_offset must be an integer, got {offset!r}")
        video = VideoEntry(_inside(path, "video.left", v.get("left")), _inside(path, "video.right", v.get("right")),
                           offset)
    housing = data.get("housing")
    if housing is not None and (not isinstance(housing, str) or housing not in housings.names()):
        raise InputFileError(str(path), f"key 'housing': must be one of {', '.join(housings.names())}")
    known = housing_known_values(path, housing, data.get("housing_known"), "housing_known")
    return Manifest(
        path=path.resolve(), name=data["name"], description=str(data.get("description", "")), housing=housing,
        housing_known=known,
        control=_inside(path, "control", data["control"]) if data.get("control") else None,
        pairs=tuple(pairs), observations=tuple(observations), calibrations=tuple(calibrations), video=video,
        truth=_inside(path, "truth", data["truth"]) if data.get("truth") else None,
    )


def housing_known_values(path: Path, kind: str | None, value: object,
                         key: str) -> dict[str, tuple[float, float | None]]:
    """Known housing values (a manifest's ``housing_known``, a scene's ``housing.known``): name → number
    (fixed) or [value, sigma] (prior), names checked against the kind; ``key`` names them in errors."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise InputFileError(str(path), f"{key}: expected an object of name: value or [value, sigma]")
    if kind is None:
        raise InputFileError(str(path), f"{key}: give the housing kind the values belong to")
    cls = housings.kind(kind)
    known = {}
    for name, item in value.items():
        try:
            cls.spec(name.rpartition("_")[0] if name in cls.calibration_names and "_" in name else name)
        except UsvipsError:
            names = sorted({s.symbol for s in cls.specs} | set(cls.calibration_names))
            raise InputFileError(str(path), f"{key}.{name}: not a parameter of the {kind} housing; "
                                 f"parameters: {', '.join(names) or 'none'}") from None
        pair = item if isinstance(item, list) else [item]
        if (len(pair) not in (1, 2) or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in pair)
                or not all(math.isfinite(v) for v in pair) or (len(pair) == 2 and not pair[1] > 0)):
            raise InputFileError(str(path), f"{key}.{name}: expected a number or [value, sigma > 0], "
                                 f"got {item!r}"[:200])
        known[name] = (float(pair[0]), float(pair[1]) if len(pair) == 2 else None)
    return known


def split_known(known: dict[str, tuple[float, float | None]]) -> tuple[dict[str, float],
                                                                      dict[str, tuple[float, float]]]:
    """Known housing values as a calibration's options: (fixed name → value, prior name → (value, sigma))."""
    return ({n: v for n, (v, s) in known.items() if s is None},
            {n: (v, s) for n, (v, s) in known.items() if s is not None})
