"""Calibration files: versioned JSON holding a :class:`StereoCalibration`.

Layout (version 1; lengths in metres, angles in radians, image quantities in pixels)::

    {"format": "usvips-calibration", "version": 1, "phase": "water",
     "housing": "dome-cover",                       # a registered kind: usvips.core.housing.names()
     "cameras": {"left":  {"interior": {"f":..., "xp":..., "yp":..., "sy":..., "k1":..., "k2":..., "p1":..., "p2":...},
                           "housing": {"a":..., ...},   # the kind's to_values(): camera frame, seeds' symbols
                           "width": 568, "height": 488},
                 "right": {...}},
     "relative_orientation": {"bx":..., "by":..., "bz":..., "omega":..., "phi":..., "kappa":...},
     "stations": [{"label": "2", "X0":..., "Y0":..., "Z0":..., "omega":..., "phi":..., "kappa":...}],
     "sigma0_px": 0.61,
     "parameters": {"f_l": {"value":..., "sigma":..., "status": "free"}, ...},
     "covariance": {"names": [...], "matrix": [[...]]},   # optional
     "statistics": {...}, "source": {...}}

The interior's ``k3`` (OpenCV's third radial term) is optional: files written before it existed load
with k3 = 0. A calibration with k3 ≠ 0 is written as version 2 (:data:`K3_VERSION`), so that a USVIPS
from before k3 refuses it ("newer than this USVIPS reads") instead of dropping the term silently;
with k3 = 0 the file stays version 1, readable by every USVIPS. Both versions load. Every other interior
term and every housing value (but ``n1``, air's 1 unless written) must be there, and a key the layout
has not is refused: read as absent, a missing term would take its default and a misspelt key would be
dropped, silently.

Files are written atomically (temporary file, then rename).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from usvips.core import housing as housings
from usvips.core.calibration.parameter_names import build_housings, exterior_of
from usvips.core.camera import EXTERIOR_PARAMETERS, Camera, Exterior
from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.housing import Housing
from usvips.core.interior import INTERIOR_PARAMETERS, Interior
from usvips.core.parameter_status import STATUSES
from usvips.core.rig import RelativeOrientation, relative_orientation
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration
from usvips.io.atomic import write_text_atomic
from usvips.io.json_text import loads_strict
from usvips.io.text_lines import not_utf8

FORMAT = "usvips-calibration"
#: The newest file version read; written only when needed (:func:`file_version`).
VERSION = 2
#: The version a file needs when a camera's k3 is not zero (version 1 readers know no k3).
K3_VERSION = 2
RELATIVE_KEYS = ("bx", "by", "bz", "omega", "phi", "kappa")
#: Largest calibration file read (bytes); a real one is a few kB.
MAX_FILE_BYTES = 16 << 20


def housing_to_dict(housing: Housing) -> dict[str, float]:
    """A camera's housing as the file holds it (its kind's :meth:`Housing.to_values`)."""
    return housing.to_values()


def housing_from_dict(kind: str, values: dict[str, float]) -> Housing:
    """A camera's housing from the file's kind and values (the registry's kind; names checked)."""
    return housings.kind(kind).from_values(values)


def _camera_to_dict(camera: Camera) -> dict:
    out = {"interior": {name: getattr(camera.interior, name) for name in INTERIOR_PARAMETERS},
           "housing": housing_to_dict(camera.housing)}
    if camera.width is not None:
        out["width"], out["height"] = camera.width, camera.height
    return out


def file_version(calibration: StereoCalibration) -> int:
    """The oldest file version that holds ``calibration`` whole: 1, or :data:`K3_VERSION` when a
    camera's k3 is not zero."""
    k3 = (calibration.left.interior.k3, calibration.right.interior.k3)
    return K3_VERSION if any(value != 0.0 for value in k3) else 1


def calibration_to_dict(calibration: StereoCalibration) -> dict:
    data = {
        "format": FORMAT, "version": file_version(calibration), "phase": calibration.phase,
        "housing": calibration.left.housing.kind,
        "cameras": {"left": _camera_to_dict(calibration.left), "right": _camera_to_dict(calibration.right)},
        "relative_orientation": {k: getattr(calibration.relative, k) for k in RELATIVE_KEYS},
        "stations": [dict(label=label, **{k: getattr(pose, k) for k in EXTERIOR_PARAMETERS})
                     for label, pose in zip(calibration.stations, calibration.poses, strict=True)],
        "sigma0_px": calibration.sigma0_px,
        "parameters": {name: {"value": p.value, "sigma": p.sigma, "status": p.status}
                       for name, p in calibration.parameters.items()},
        "statistics": calibration.statistics,
        "source": calibration.source,
    }
    if calibration.covariance is not None:
        names, matrix = calibration.covariance
        matrix = np.asarray(matrix, dtype=np.float64)
        # the adjustment's inverse is symmetric only to rounding: write the symmetric part, so that what
        # we write is what our reader accepts
        data["covariance"] = {"names": list(names), "matrix": (0.5 * (matrix + matrix.T)).tolist()}
    return data


#: every key a calibration file's top level may hold (a misspelt "covariance" would drop the calibration's
#: uncertainty from every sigma, silently)
TOP_KEYS = ("format", "version", "phase", "housing", "cameras", "relative_orientation", "stations", "sigma0_px",
            "parameters", "covariance", "statistics", "source")
#: every key of a camera in a calibration file
CAMERA_KEYS = ("interior", "housing", "width", "height")


def _require(path: str, data: dict, key: str, kind: type | tuple[type, ...]) -> object:
    if key not in data:
        raise InputFileError(path, f"missing key {key!r}")
    value = data[key]
    if not isinstance(value, kind):
        raise InputFileError(path, f"key {key!r} has the wrong type ({type(value).__name__})")
    return value


#: no housing parameter (metres, slopes, refractive indices) is this large: a larger one is a damaged file
HOUSING_VALUE_LIMIT = 1000.0


def _numbers(path: str, where: str, data: dict, keys: tuple[str, ...], optional: bool = False) -> dict:
    out = {}
    for key in keys:
        if key not in data:
            if optional:
                continue
            raise InputFileError(path, f"{where}: missing parameter {key!r}")
        value = data[key]
        if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
            raise InputFileError(path, f"{where}: parameter {key!r} must be a finite number, got {value!r}")
        out[key] = float(value)
    return out


def _known_only(path: str, where: str, data: dict, keys: tuple[str, ...], what: str) -> None:
    """Refuse a key of ``data`` that is none of ``keys`` (a term this file format has not, e.g. a fourth radial
    term, or a misspelt key: read as absent, it would be silently dropped)."""
    unknown = [key for key in data if key not in keys]
    if unknown:
        raise InputFileError(path, f"{where}.{unknown[0]}: not {what} (they are {', '.join(keys)})")


def _show(value: object) -> str:
    text = json.dumps(value) if isinstance(value, int | float | bool | str | None) else type(value).__name__
    return text if len(text) <= 24 else text[:23] + "…"


def _finite(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _parameters(path: str, data: object) -> dict[str, ParameterEstimate]:
    """``parameters``: name → {"value": number, "sigma": number >= 0 or null, "status": free|fixed|prior}."""
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise InputFileError(path, f"parameters: must be an object of name → {{value, sigma, status}}, got "
                             f"{type(data).__name__}")
    parameters = {}
    for name, entry in data.items():
        if not isinstance(entry, dict) or "value" not in entry:
            raise InputFileError(path, f"parameters.{name}: expected {{'value': ..., 'sigma': ...}}")
        if not _finite(entry["value"]):
            raise InputFileError(path, f"parameters.{name}.value: must be a finite number, got {_show(entry['value'])}")
        sigma = entry.get("sigma")
        if sigma is not None and not (_finite(sigma) and sigma >= 0):
            raise InputFileError(path, f"parameters.{name}.sigma: must be a finite number >= 0 or null, got "
                                 f"{_show(sigma)}")
        status = entry.get("status", "free")
        if not isinstance(status, str) or status not in STATUSES:
            raise InputFileError(path, f"parameters.{name}.status: must be one of {', '.join(STATUSES)}, got "
                                 f"{_show(status)}")
        parameters[name] = ParameterEstimate(float(entry["value"]), None if sigma is None else float(sigma), status)
    return parameters


#: Largest accepted |C_ij − C_ji| / sqrt(C_ii C_jj) (the asymmetry in units of the two parameters' sigmas):
#: a covariance's entries span many orders of magnitude (px² beside rad²), so the tolerance is relative to
#: each entry's own scale, far above rounding (1e-16) and far below any real disagreement.
SYMMETRY_TOLERANCE = 1e-9


def _relative_asymmetry(matrix: np.ndarray) -> float:
    """max |C_ij − C_ji| / sqrt(|C_ii C_jj|) (a zero diagonal counts at the matrix's largest entry)."""
    if not matrix.size:
        return 0.0
    diagonal = np.abs(np.diag(matrix))
    floor = 1e-300 + float(np.max(np.abs(matrix))) * 1e-30
    scale = np.sqrt(np.maximum(np.outer(diagonal, diagonal), floor ** 2))
    return float(np.max(np.abs(matrix - matrix.T) / scale))


def _covariance(path: str, data: object) -> tuple[tuple[str, ...], np.ndarray] | None:
    """``covariance``: {"names": [n strings], "matrix": n × n finite numbers, symmetric positive semi-definite}."""
    if data is None:
        return None
    if not isinstance(data, dict):
        raise InputFileError(path, f"covariance: must be an object {{names, matrix}}, got {type(data).__name__}")
    names, rows = data.get("names"), data.get("matrix")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names) or len(set(names)) != len(names):
        raise InputFileError(path, "covariance.names: must be a list of distinct parameter names")
    if (not isinstance(rows, list) or len(rows) != len(names)
            or not all(isinstance(r, list) and len(r) == len(names) and all(_finite(v) for v in r) for r in rows)):
        raise InputFileError(path, f"covariance.matrix: must be {len(names)} × {len(names)} finite numbers "
                             "(one row and column per name)")
    matrix = np.array(rows, dtype=np.float64).reshape(len(names), len(names))
    scale = float(np.max(np.abs(matrix))) if matrix.size else 0.0
    asymmetry = _relative_asymmetry(matrix)
    if asymmetry > SYMMETRY_TOLERANCE:
        raise InputFileError(path, f"covariance.matrix: not symmetric (an asymmetry of {asymmetry:.2g} of the "
                             f"entries' scale, tolerance {SYMMETRY_TOLERANCE:g})")
    negative = [names[i] for i in np.flatnonzero(np.diag(matrix) < 0)]
    if negative:
        raise InputFileError(path, f"covariance.matrix: negative variance of {negative[0]} (not a covariance)")
    if matrix.size and float(np.linalg.eigvalsh(matrix).min()) < -1e-9 * max(scale, 1e-300):
        raise InputFileError(path, "covariance.matrix: not positive semi-definite (a negative eigenvalue); "
                             "not a covariance")
    return tuple(names), matrix


def calibration_from_dict(data: dict, path: str = "<calibration>") -> StereoCalibration:
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputFileError(path, f"not a USVIPS calibration file (\"format\" must be {FORMAT!r})")
    version = data.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise InputFileError(path, f"version: must be a whole number from 1, got {_show(version)}")
    if version > VERSION:
        raise InputFileError(path, f"calibration file version {version!r} is newer than this USVIPS reads "
                             f"({VERSION}); update USVIPS")
    try:
        _known_only(path, "calibration", data, TOP_KEYS, "a key of a calibration file")
        kind = _require(path, data, "housing", str)
        cameras = _require(path, data, "cameras", dict)
        _known_only(path, "cameras", cameras, ("left", "right"), "a camera")
        built = {}
        for side in ("left", "right"):
            cam = _require(path, cameras, side, dict)
            _known_only(path, f"cameras.{side}.interior", _require(path, cam, "interior", dict), INTERIOR_PARAMETERS,
                        "an interior parameter")
            _known_only(path, f"cameras.{side}", cam, CAMERA_KEYS, "a key of a camera")
            interior = Interior(**_numbers(path, f"{side} interior", _require(path, cam, "interior", dict),
                                           INTERIOR_PARAMETERS[:-1]) |
                                _numbers(path, f"{side} interior", cam["interior"], INTERIOR_PARAMETERS[-1:], True))
            housing_values = _require(path, cam, "housing", dict)
            housing_numbers = _numbers(path, f"{side} housing", housing_values, tuple(housing_values))
            for key, value in housing_numbers.items():
                if abs(value) > HOUSING_VALUE_LIMIT:
                    raise InputFileError(path, f"cameras.{side}.housing.{key}: {value:g} is not a housing value "
                                               f"(metres, slopes and indices are within ±{HOUSING_VALUE_LIMIT:g})")
            housing = housing_from_dict(kind, housing_numbers)
            # a value with a default (a refractive index) left out would be read as the default, silently
            missing = [key for key in housing.to_values() if key not in housing_numbers and key != "n1"]
            if missing:
                raise InputFileError(path, f"cameras.{side}.housing: missing parameter {missing[0]!r} of the {kind} "
                                     "housing")
            width, height = cam.get("width"), cam.get("height")
            if (width is None) != (height is None):
                raise InputFileError(path, f"cameras.{side}: give both width and height, or neither")
            for key, value in (("width", width), ("height", height)):
                if value is not None and not (isinstance(value, int) and not isinstance(value, bool)
                                              and 1 <= value <= 1_000_000):
                    raise InputFileError(path, f"cameras.{side}.{key}: must be a positive whole number of pixels, "
                                         f"got {_show(value)}")
            built[side] = (interior, housing, width, height)
        _known_only(path, "relative_orientation", _require(path, data, "relative_orientation", dict), RELATIVE_KEYS,
                    "a relative orientation parameter")
        relative = RelativeOrientation(**_numbers(path, "relative_orientation",
                                                  _require(path, data, "relative_orientation", dict), RELATIVE_KEYS))
        stations_data = _require(path, data, "stations", list)
        labels, poses = [], []
        for i, station in enumerate(stations_data):
            if not isinstance(station, dict):
                raise InputFileError(path, f"stations[{i}] must be an object")
            label = station.get("label", i + 1)
            if isinstance(label, bool) or not isinstance(label, str | int) or not str(label).strip():
                raise InputFileError(path, f"stations[{i}].label must be a name or a number, got {_show(label)}")
            if str(label) in labels:
                raise InputFileError(path, f"stations[{i}].label {str(label)!r} is the label of stations["
                                     f"{labels.index(str(label))}] too: a station is chosen by its label")
            labels.append(str(label))
            _known_only(path, f"stations[{i}]", station, ("label", *EXTERIOR_PARAMETERS), "a key of a station")
            poses.append(Exterior(**_numbers(path, f"stations[{i}]", station, EXTERIOR_PARAMETERS)))
        if not poses:
            raise InputFileError(path, "the calibration has no station")
        left = Camera(built["left"][0], poses[0], built["left"][1], built["left"][2], built["left"][3])
        right = Camera(built["right"][0], poses[0], built["right"][1], built["right"][2], built["right"][3])
        parameters = _parameters(path, data.get("parameters"))
        covariance = _covariance(path, data.get("covariance"))
        if parameters:  # an interior term the file predates (k3) enters as fixed at the camera's value
            for side, camera in (("l", left), ("r", right)):
                for name in INTERIOR_PARAMETERS:
                    parameters.setdefault(f"{name}_{side}",
                                          ParameterEstimate(float(getattr(camera.interior, name)), None, "fixed"))
        if covariance is not None:
            _require_model_parameters(path, kind, tuple(labels), parameters, covariance)
        _require_parameters_agree(path, kind, tuple(labels), parameters, left, right, poses, relative)
        sigma0 = _numbers(path, "calibration", data, ("sigma0_px",))["sigma0_px"]
        if sigma0 < 0:
            raise InputFileError(path, f"sigma0_px: must be >= 0, got {sigma0!r}")
        for key in ("statistics", "source"):
            if data.get(key) is not None and not isinstance(data[key], dict):
                raise InputFileError(path, f"{key}: must be an object, got {type(data[key]).__name__}")
        phase = data.get("phase")
        if phase is not None and not isinstance(phase, str):
            raise InputFileError(path, f"phase: must be a string, got {_show(phase)}")
        return StereoCalibration(left, right, tuple(labels), tuple(poses), relative, str(phase),
                                 sigma0, parameters, covariance, dict(data.get("statistics") or {}),
                                 dict(data.get("source") or {}))
    except InputFileError:
        raise
    except (UsvipsError, TypeError, ValueError) as error:
        raise InputFileError(path, str(error)) from None


def _require_model_parameters(path: str, kind: str, stations: tuple[str, ...],
                              parameters: dict[str, ParameterEstimate], covariance) -> None:
    """With a covariance, every parameter the calibration's model is built from is in ``parameters`` (the
    uncertainty propagation rebuilds the cameras from them) and the covariance names only parameters.
    (Without one, parameters may list a part, e.g. an OpenCV import's interior.)"""
    needed = [f"{p}_{side}" for side in ("l", "r") for p in EXTERIOR_PARAMETERS]
    needed += [f"{p}_l@{station}" for station in stations[1:] for p in EXTERIOR_PARAMETERS]
    needed += list(housings.kind(kind).calibration_names)
    missing = [name for name in needed if name not in parameters]
    if missing:
        raise InputFileError(path, f"parameters: missing {', '.join(missing)} (the {kind} model with stations "
                                   f"{', '.join(stations)} and a covariance needs each of them)")
    unknown = [name for name in covariance[0] if name not in parameters]
    if unknown:
        raise InputFileError(path, f"covariance: names {', '.join(unknown)}, which are not in parameters")


#: Largest accepted |parameter − camera value| / max(1, |either|): far above a float's rounding through the
#: relative orientation (1e-15), far below any edit a person makes.
AGREEMENT_TOLERANCE = 1e-7


def _agree(given: float, camera_value: float) -> bool:
    """Whether a parameter's value is the camera's (within :data:`AGREEMENT_TOLERANCE` of its size)."""
    return abs(given - camera_value) <= AGREEMENT_TOLERANCE * max(1.0, abs(given), abs(camera_value))


def _disagreement(name: str, given: float, camera_value: float, where: str) -> str | None:
    """A message when the parameter's value is not the camera's, else None."""
    if _agree(given, camera_value):
        return None
    return f"parameters.{name}: value {given!r} is not the cameras' {camera_value!r} ({where})"


def _housing_disagreements(kind: str, values: dict[str, float], left: Camera, right: Camera) -> list[str]:
    """Messages for each housing value the kind builds from the parameters that is not the camera's."""
    names = ", ".join(housings.kind(kind).calibration_names)
    try:
        built = build_housings(kind, values)
    except UsvipsError as error:
        return [f"parameters {names}: they make no {kind} housing ({error})"]
    problems = []
    for word, housing, camera in zip(("left", "right"), built, (left, right), strict=True):
        expected = camera.housing.to_values()
        for key, value in housing.to_values().items():
            if key in expected and not _agree(value, float(expected[key])):
                problems.append(f"parameters {names}: the {word} housing they make has {key} = {value!r}, not the "
                                f"cameras' {float(expected[key])!r} (cameras.{word}.housing.{key})")
    return problems


def _require_parameters_agree(path: str, kind: str, stations: tuple[str, ...],
                              parameters: dict[str, ParameterEstimate], left: Camera, right: Camera,
                              poses: list[Exterior], relative: RelativeOrientation) -> None:
    """Every parameter that names a part of the cameras holds the cameras' value: the uncertainty
    propagation and a later phase's priors are built from ``parameters``, the measurements from
    ``cameras``, ``stations`` and ``relative_orientation`` — a hand edit of one and not the other would be
    used by half the program. Interior terms and the left poses are compared value by value; the right
    camera's first pose as the relative orientation it makes (rotation and base); the housings as the
    kind builds them from the parameters."""
    values = {name: p.value for name, p in parameters.items()}
    problems = []
    for side, word, camera in (("l", "left", left), ("r", "right", right)):
        problems += [_disagreement(f"{p}_{side}", values[f"{p}_{side}"], float(getattr(camera.interior, p)),
                                   f"cameras.{word}.interior.{p}")
                     for p in INTERIOR_PARAMETERS if f"{p}_{side}" in values]
    for i, (label, pose) in enumerate(zip(stations, poses, strict=True)):
        suffix = "_l" if i == 0 else f"_l@{label}"
        problems += [_disagreement(p + suffix, values[p + suffix], float(getattr(pose, p)), f"stations[{i}].{p}")
                     for p in EXTERIOR_PARAMETERS if p + suffix in values]
    right_names = [f"{p}_r" for p in EXTERIOR_PARAMETERS]
    left_names = [f"{p}_l" for p in EXTERIOR_PARAMETERS]
    if all(n in values for n in right_names + left_names):
        implied = relative_orientation(exterior_of(values, "l"), exterior_of(values, "r"))
        if not (np.allclose(implied.rotation, relative.rotation, rtol=0, atol=AGREEMENT_TOLERANCE)
                and np.allclose(implied.base, relative.base, rtol=0,
                                atol=AGREEMENT_TOLERANCE * max(1.0, float(np.abs(relative.base).max())))):
            problems.append(f"parameters {', '.join(right_names)}: the right camera's pose they give is not the "
                            f"one relative_orientation gives")
    housing_names = list(housings.kind(kind).calibration_names)
    if housing_names and all(n in values for n in housing_names) and (
            not housings.kind(kind).right_follows_rig or all(n in values for n in right_names + left_names)):
        problems += _housing_disagreements(kind, values, left, right)
    problems = [p for p in problems if p]
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise InputFileError(path, f"{problems[0]}{more}: a calibration's parameters and its cameras must hold "
                                   f"the same values")


def load_calibration(path: str | Path) -> StereoCalibration:
    """Read a calibration file; raises :class:`InputFileError` naming the file and what is wrong."""
    path = Path(path)
    text = ""
    if not path.is_file():
        raise InputFileError(str(path), "no such calibration file")
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise InputFileError(str(path), f"too large for a calibration file (over {MAX_FILE_BYTES >> 20} MiB)")
        text = path.read_text(encoding="utf-8-sig")
        data = loads_strict(text, path)
    except json.JSONDecodeError as error:
        if text.lstrip().startswith(("%YAML", "<?xml", "<opencv_storage")) or "!!opencv-matrix" in text:
            raise InputFileError(str(path), "an OpenCV calibration (YAML/XML), not a USVIPS one: convert it first "
                                 "with usvips calibration import") from None
        raise InputFileError(str(path), f"not valid JSON: {error.msg}", error.lineno) from None
    except UnicodeDecodeError as error:
        raise not_utf8(str(path), error.object, error.start, "calibration file (JSON)") from None
    except RecursionError:
        raise InputFileError(str(path), "nested too deeply to be a calibration file") from None
    except OSError as error:
        raise InputFileError(str(path), f"cannot read the file: {error.strerror or error}") from None
    return calibration_from_dict(data, str(path))


def write_json_atomic(path: str | Path, data: dict) -> None:
    """Write JSON to ``path`` atomically (no partial file on error)."""
    write_text_atomic(path, json.dumps(data, indent=2, allow_nan=False) + "\n")


def save_calibration(calibration: StereoCalibration, path: str | Path) -> None:
    """Write a calibration file atomically."""
    write_json_atomic(path, calibration_to_dict(calibration))
