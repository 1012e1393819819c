"""Model description files: what a detection model expects and gives, so that a user's own ONNX model
runs from its description alone (docs/detection.md). TOML (``.toml``) or JSON (``.json``), the same keys:

    [model]          file (the .onnx, relative to the description's folder), family ("yolo-pose"),
                     input_width, input_height (pixels)
    [normalisation]  scale (e.g. 1/255), mean, std (3 numbers each, in the model's channel order),
                     channels ("RGB" or "BGR")
    [output]         classes (names in the model's order), keypoints (names in order, e.g. snout, fork),
                     keypoint_values (3: x, y, visibility; 2: x, y), objectness (true: an objectness
                     score precedes the class scores), score_threshold, iou_threshold (0..1), max_detections
    [keypoint_sigma] optional, each keypoint's measured pointing σ in IMAGE pixels: px = {snout = …, …},
                     basis (what it was measured on); the σ lengths are given (usvips.core.detection.keypoint_sigma)
    [validation]     optional, measured on held-out data: keypoint_sigma (pointing σ per keypoint, INPUT
                     pixels: used, scaled by the letterbox, where [keypoint_sigma] gives none), recall,
                     precision (0..1), median_error (per keypoint, input pixels), source (text)
    [stereo_sigma]   optional, how the refined stereo keypoints err by the fish's size, measured on rendered
                     clips (usvips.training.stereo_sigma): left = {snout = [a, b], …} (the left keypoint's σ,
                     INPUT pixels), match = {snout = [a, b], …} (the refined right keypoint about the left's
                     conjugate, IMAGE pixels), optionally unmatched = {snout = [a, b], …} (a right keypoint
                     the match did not refine, INPUT pixels), each σ(s) = √(a² + (b·s)²) for a fish s px
                     long; basis (text)
    [frame_correlation] optional, how alike the model errs on one fish from frame to frame, measured on
                     rendered clips (usvips.training.frame_correlation): length (the correlation of two
                     frames' length errors, in [0, 1)), basis (text); a fish's lengths joined over frames are
                     combined with it (usvips.core.measurements.instants)

Every bad field is one :class:`~usvips.core.errors.InputFileError` naming the file and the key.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

from usvips.core.detection.description import CHANNEL_ORDERS, ModelDescription
from usvips.core.detection.keypoint_sigma import SizeSigma, StereoSigma
from usvips.core.detection.registry import family, names
from usvips.core.detection.runner import OnnxDetector
from usvips.core.errors import InputFileError, InvalidParameterError
from usvips.io.file_errors import not_a_file

SECTIONS = {"model": ("file", "family", "input_width", "input_height"),
            "normalisation": ("scale", "mean", "std", "channels"),
            "output": ("classes", "keypoints", "keypoint_values", "objectness", "score_threshold",
                       "iou_threshold", "max_detections"),
            "keypoint_sigma": ("px", "basis"),
            "validation": ("keypoint_sigma", "recall", "precision", "median_error", "source"),
            "stereo_sigma": ("left", "match", "unmatched", "basis"),
            "frame_correlation": ("length", "basis")}
REQUIRED = ("model.file", "model.family", "model.input_width", "model.input_height", "output.classes",
            "output.keypoints")


class _Fields:
    """The parsed tables of one file, read key by key with errors naming the file and the key."""

    def __init__(self, path: Path, tables: dict) -> None:
        self.path, self.tables = path, tables

    def fail(self, key: str, problem: str) -> InputFileError:
        return InputFileError(str(self.path), f"{key}: {problem}")

    def get(self, key: str, default=None):
        section, _, name = key.partition(".")
        table = self.tables.get(section, {})
        if name not in table:
            if key in REQUIRED:
                raise self.fail(key, "missing")
            return default
        return table[name]

    def integer(self, key: str, default: int | None = None, low: int = 1, high: int = 100_000) -> int:
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise self.fail(key, f"expected a whole number from {low} to {high}, got {value!r}")
        return value

    def number(self, key: str, default: float, low: float = -math.inf, high: float = math.inf,
               positive: bool = False) -> float:
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) \
                or not low <= value <= high or (positive and value <= 0):
            where = "> 0" if positive else f"in [{low:g}, {high:g}]"
            raise self.fail(key, f"expected a finite number {where}, got {value!r}")
        return float(value)

    def triple(self, key: str, default: tuple[float, float, float], positive: bool = False) -> tuple[float, ...]:
        value = self.get(key, default)
        if isinstance(value, int | float) and not isinstance(value, bool):
            value = [value] * 3
        if not isinstance(value, list | tuple) or len(value) != 3 or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and (v > 0 or not positive)
                for v in value):
            raise self.fail(key, f"expected 3 finite numbers{' > 0' if positive else ''} (one per channel), "
                                 f"got {value!r}")
        return tuple(float(v) for v in value)

    def per_keypoint(self, key: str, count: int) -> tuple[float, ...]:
        """A list of ``count`` finite numbers > 0 (one per keypoint), or () when the key is absent."""
        value = self.get(key, ())
        if value == ():
            return ()
        if not isinstance(value, list) or len(value) != count or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0 for v in value):
            raise self.fail(key, f"expected {count} finite numbers > 0 (one per keypoint), got {value!r}")
        return tuple(float(v) for v in value)

    def flag(self, key: str, default: bool) -> bool:
        value = self.get(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, f"expected true or false, got {value!r}")
        return value

    def names(self, key: str) -> tuple[str, ...]:
        value = self.get(key)
        if not isinstance(value, list) or not all(isinstance(v, str) and v.strip() for v in value):
            raise self.fail(key, f"expected a list of names, got {value!r}")
        if len(set(value)) != len(value):
            raise self.fail(key, f"names repeat: {value!r}")
        return tuple(v.strip() for v in value)

    def text(self, key: str, default: str | None = None, choices: tuple[str, ...] | None = None) -> str:
        value = self.get(key, default)
        if not isinstance(value, str) or not value.strip() or (choices and value not in choices):
            expected = f"one of {', '.join(choices)}" if choices else "a text"
            raise self.fail(key, f"expected {expected}, got {value!r}")
        return value.strip()


def _tables(path: Path) -> dict:
    if not path.is_file():
        raise not_a_file(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise InputFileError(str(path), f"cannot be read as UTF-8 text: {error}") from None
    suffix = path.suffix.lower()
    try:
        if suffix == ".toml":
            tables = tomllib.loads(text)
        elif suffix == ".json":
            tables = json.loads(text)
        else:
            raise InputFileError(str(path), f"unknown description format {suffix or '(none)'!r}: expected .toml "
                                            "or .json")
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as error:
        raise InputFileError(str(path), f"not valid {suffix[1:].upper()}: {error}") from None
    if not isinstance(tables, dict):
        raise InputFileError(str(path), "expected the tables model, normalisation and output")
    for section, value in tables.items():
        if section not in SECTIONS:
            raise InputFileError(str(path), f"{section}: unknown section; known: {', '.join(SECTIONS)}")
        if not isinstance(value, dict):
            raise InputFileError(str(path), f"{section}: expected a table of keys")
        unknown = sorted(set(value) - set(SECTIONS[section]))
        if unknown:
            raise InputFileError(str(path), f"{section}.{unknown[0]}: unknown key; known: "
                                            f"{', '.join(SECTIONS[section])}")
    return tables


def _sigmas(fields: _Fields, keypoints: tuple[str, ...]) -> tuple[tuple[str, float], ...]:
    table = fields.get("keypoint_sigma.px", {})
    if not isinstance(table, dict):
        raise fields.fail("keypoint_sigma.px", f"expected a table of keypoint = sigma (px), got {table!r}")
    out = []
    for name, value in table.items():
        if name not in keypoints:
            raise fields.fail(f"keypoint_sigma.px.{name}", f"not one of the model's keypoints ({', '.join(keypoints)})")
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
            raise fields.fail(f"keypoint_sigma.px.{name}", f"expected a finite sigma > 0 (px), got {value!r}")
        out.append((str(name), float(value)))
    return tuple(out)


def _size_sigmas(fields: _Fields, key: str, keypoints: tuple[str, ...]) -> dict[str, SizeSigma]:
    table = fields.get(key, {})
    if not isinstance(table, dict) or not table:
        raise fields.fail(key, f"expected a table of keypoint = [a, b] (px, px per px), got {table!r}")
    out = {}
    for name, value in table.items():
        if name not in keypoints:
            raise fields.fail(f"{key}.{name}", f"not one of the model's keypoints ({', '.join(keypoints)})")
        if not (isinstance(value, list) and len(value) == 2 and all(
                not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v) and v >= 0 for v in value)
                and value[0] + value[1] > 0):
            raise fields.fail(f"{key}.{name}", f"expected [a, b]: finite, >= 0 and not both 0, got {value!r}")
        out[str(name)] = SizeSigma(float(value[0]), float(value[1]))
    return out


def _stereo_sigma(fields: _Fields, keypoints: tuple[str, ...]) -> StereoSigma | None:
    if "stereo_sigma" not in fields.tables:
        return None
    basis = fields.get("stereo_sigma.basis", "")
    if not isinstance(basis, str):
        raise fields.fail("stereo_sigma.basis", f"expected a text, got {basis!r}")
    left, match = (_size_sigmas(fields, f"stereo_sigma.{k}", keypoints) for k in ("left", "match"))
    if set(left) != set(match):
        raise fields.fail("stereo_sigma.match", f"names other keypoints ({', '.join(match)}) than stereo_sigma.left "
                                                f"({', '.join(left)})")
    unmatched = (_size_sigmas(fields, "stereo_sigma.unmatched", keypoints)
                 if fields.get("stereo_sigma.unmatched") is not None else {})
    return StereoSigma(left, match, basis.strip(), unmatched)


def _frame_correlation(fields: _Fields) -> tuple[float | None, str]:
    if "frame_correlation" not in fields.tables:
        return None, ""
    if fields.get("frame_correlation.length") is None:
        raise fields.fail("frame_correlation.length", "missing")
    value = fields.number("frame_correlation.length", 0.0, 0.0, 1.0)
    if value >= 1.0:
        raise fields.fail("frame_correlation.length", "must be below 1 (errors shared whole are not measured; "
                                                      "they are instants tracked from one pick)")
    basis = fields.get("frame_correlation.basis", "")
    if not isinstance(basis, str):
        raise fields.fail("frame_correlation.basis", f"expected a text, got {basis!r}")
    return value, basis.strip()


def read_model_description(path: str | Path) -> ModelDescription:
    """The :class:`ModelDescription` a TOML or JSON file holds (the model file is not read)."""
    path = Path(path)
    fields = _Fields(path, _tables(path))
    kind = fields.text("model.family")
    if kind not in names():
        raise fields.fail("model.family", f"unknown model family {kind!r}; known: {', '.join(names())}")
    defaults = ModelDescription("", kind, 1, 1, (), ())
    keypoints = fields.names("output.keypoints")
    basis = fields.get("keypoint_sigma.basis", "")
    if not isinstance(basis, str):
        raise fields.fail("keypoint_sigma.basis", f"expected a text, got {basis!r}")
    correlation, correlation_basis = _frame_correlation(fields)
    description = ModelDescription(
        model=fields.text("model.file"), family=kind,
        input_width=fields.integer("model.input_width", high=16384),
        input_height=fields.integer("model.input_height", high=16384),
        class_names=fields.names("output.classes"), keypoint_names=keypoints,
        scale=fields.number("normalisation.scale", defaults.scale, positive=True),
        mean=fields.triple("normalisation.mean", defaults.mean),
        std=fields.triple("normalisation.std", defaults.std, positive=True),
        channel_order=fields.text("normalisation.channels", defaults.channel_order, CHANNEL_ORDERS),
        keypoint_values=fields.integer("output.keypoint_values", defaults.keypoint_values, high=3),
        objectness=fields.flag("output.objectness", defaults.objectness),
        score_threshold=fields.number("output.score_threshold", defaults.score_threshold, 0.0, 1.0),
        iou_threshold=fields.number("output.iou_threshold", defaults.iou_threshold, 0.0, 1.0),
        max_detections=fields.integer("output.max_detections", defaults.max_detections),
        keypoint_sigma_px=_sigmas(fields, keypoints), keypoint_sigma_basis=basis.strip(),
        validated_keypoint_sigma=fields.per_keypoint("validation.keypoint_sigma",
                                                     len(fields.names("output.keypoints"))),
        validation_source=(fields.text("validation.source").strip()
                           if fields.get("validation.source") is not None else ""),
        stereo_sigma=_stereo_sigma(fields, keypoints),
        frame_correlation=correlation, frame_correlation_basis=correlation_basis)
    fields.per_keypoint("validation.median_error", len(description.keypoint_names))
    for key in ("validation.recall", "validation.precision"):
        fields.number(key, 0.0, 0.0, 1.0)
    try:
        family(kind).check(description)
    except InvalidParameterError as error:
        raise fields.fail(f"output.{error.parameter}", error.problem) from None
    return description


def model_path(description_path: str | Path, description: ModelDescription) -> Path:
    """The model file a description names, relative to the description's folder."""
    return Path(description_path).parent / description.model


def read_model_file(description_path: str | Path, description: ModelDescription) -> tuple[Path, bytes]:
    """The model file a description names and its bytes; a missing or unreadable one is an
    :class:`InputFileError` (naming the description for a missing file, the model for an unreadable one)."""
    model = model_path(description_path, description)
    if not model.is_file():
        raise InputFileError(str(description_path), f"model.file: no such file {str(model)!r}")
    try:
        return model, model.read_bytes()
    except OSError as error:
        raise InputFileError(str(model), f"cannot be read: {error}") from None


def onnx_detector(description: ModelDescription, data: bytes, model: Path) -> OnnxDetector:
    """A detector on OpenCV's DNN module for ``data``, the bytes of the model file ``model``; a network
    OpenCV refuses is an :class:`InputFileError` naming the model file."""
    try:
        return OnnxDetector(description, data)
    except InvalidParameterError as error:
        raise InputFileError(str(model), error.problem) from None


def load_detector(path: str | Path) -> OnnxDetector:
    """The detector a description file describes: its model file read and handed to OpenCV's DNN module."""
    description = read_model_description(path)
    model, data = read_model_file(path, description)
    return onnx_detector(description, data, model)
