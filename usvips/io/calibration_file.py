"""Calibration files: versioned JSON holding a :class:`StereoCalibration`.

Layout (version 1; lengths in metres, angles in radians, image quantities in pixels)::

    {"format": "usvips-calibration", "version": 1, "phase": "water",
     "housing": "dome-cover",                       # air | dome-cover | flat-port
     "cameras": {"left":  {"interior": {"f":..., "xp":..., "yp":..., "sy":..., "k1":..., "k2":..., "p1":..., "p2":...},
                           "housing": {"a":..., ...},   # camera frame, seeds' symbols
                           "width": 568, "height": 488},
                 "right": {...}},
     "relative_orientation": {"bx":..., "by":..., "bz":..., "omega":..., "phi":..., "kappa":...},
     "stations": [{"label": "2", "X0":..., "Y0":..., "Z0":..., "omega":..., "phi":..., "kappa":...}],
     "sigma0_px": 0.61,
     "parameters": {"f_l": {"value":..., "sigma":..., "status": "free"}, ...},
     "covariance": {"names": [...], "matrix": [[...]]},   # optional
     "statistics": {...}, "source": {...}}

The interior's ``k3`` (OpenCV's third radial term) is optional: files written before it existed load
with k3 = 0.

Files are written atomically (temporary file, then rename).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from usvips.core.camera import EXTERIOR_PARAMETERS, Camera, Exterior
from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.housing import AirHousing, DomeCoverHousing, FlatPortHousing, Housing
from usvips.core.interior import INTERIOR_PARAMETERS, Interior
from usvips.core.rig import RelativeOrientation
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration
from usvips.io.atomic import write_text_atomic

FORMAT = "usvips-calibration"
VERSION = 1
HOUSING_KINDS = {"air": AirHousing, "dome-cover": DomeCoverHousing, "flat-port": FlatPortHousing}
RELATIVE_KEYS = ("bx", "by", "bz", "omega", "phi", "kappa")


def housing_to_dict(housing: Housing) -> dict[str, float]:
    values = housing.parameters()
    if isinstance(housing, DomeCoverHousing | FlatPortHousing) and housing.n1 != 1.0:
        values["n1"] = housing.n1
    return values


def housing_from_dict(kind: str, values: dict[str, float]) -> Housing:
    if kind not in HOUSING_KINDS:
        raise UsvipsError(f"unknown housing kind {kind!r}; known: {', '.join(HOUSING_KINDS)}")
    return HOUSING_KINDS[kind](**values)


def _camera_to_dict(camera: Camera) -> dict:
    out = {"interior": {name: getattr(camera.interior, name) for name in INTERIOR_PARAMETERS},
           "housing": housing_to_dict(camera.housing)}
    if camera.width is not None:
        out["width"], out["height"] = camera.width, camera.height
    return out


def calibration_to_dict(calibration: StereoCalibration) -> dict:
    data = {
        "format": FORMAT, "version": VERSION, "phase": calibration.phase,
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
        data["covariance"] = {"names": list(names), "matrix": np.asarray(matrix).tolist()}
    return data


def _require(path: str, data: dict, key: str, kind: type | tuple[type, ...]) -> object:
    if key not in data:
        raise InputFileError(path, f"missing key {key!r}")
    value = data[key]
    if not isinstance(value, kind):
        raise InputFileError(path, f"key {key!r} has the wrong type ({type(value).__name__})")
    return value


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


def calibration_from_dict(data: dict, path: str = "<calibration>") -> StereoCalibration:
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputFileError(path, f"not a USVIPS calibration file (\"format\" must be {FORMAT!r})")
    version = data.get("version")
    if not isinstance(version, int) or version > VERSION:
        raise InputFileError(path, f"calibration file version {version!r} is newer than this USVIPS reads "
                             f"({VERSION}); update USVIPS")
    try:
        kind = _require(path, data, "housing", str)
        cameras = _require(path, data, "cameras", dict)
        built = {}
        for side in ("left", "right"):
            cam = _require(path, cameras, side, dict)
            interior = Interior(**_numbers(path, f"{side} interior", _require(path, cam, "interior", dict),
                                           INTERIOR_PARAMETERS[:3]) |
                                _numbers(path, f"{side} interior", cam["interior"], INTERIOR_PARAMETERS[3:], True))
            housing_values = _require(path, cam, "housing", dict)
            housing = housing_from_dict(kind, _numbers(path, f"{side} housing", housing_values,
                                                       tuple(housing_values)))
            width, height = cam.get("width"), cam.get("height")
            built[side] = (interior, housing, width, height)
        relative = RelativeOrientation(**_numbers(path, "relative_orientation",
                                                  _require(path, data, "relative_orientation", dict), RELATIVE_KEYS))
        stations_data = _require(path, data, "stations", list)
        labels, poses = [], []
        for i, station in enumerate(stations_data):
            if not isinstance(station, dict):
                raise InputFileError(path, f"stations[{i}] must be an object")
            labels.append(str(station.get("label", i + 1)))
            poses.append(Exterior(**_numbers(path, f"stations[{i}]", station, EXTERIOR_PARAMETERS)))
        if not poses:
            raise InputFileError(path, "the calibration has no station")
        left = Camera(built["left"][0], poses[0], built["left"][1], built["left"][2], built["left"][3])
        right = Camera(built["right"][0], poses[0], built["right"][1], built["right"][2], built["right"][3])
        parameters = {}
        for name, entry in (data.get("parameters") or {}).items():
            if not isinstance(entry, dict) or "value" not in entry:
                raise InputFileError(path, f"parameters.{name}: expected {{'value': ..., 'sigma': ...}}")
            parameters[name] = ParameterEstimate(float(entry["value"]),
                                                 None if entry.get("sigma") is None else float(entry["sigma"]),
                                                 str(entry.get("status", "free")))
        if parameters:  # an interior term the file predates (k3) enters as fixed at the camera's value
            for side, camera in (("l", left), ("r", right)):
                for name in INTERIOR_PARAMETERS:
                    parameters.setdefault(f"{name}_{side}",
                                          ParameterEstimate(float(getattr(camera.interior, name)), None, "fixed"))
        covariance = None
        if data.get("covariance") is not None:
            cov = data["covariance"]
            names = tuple(cov.get("names", ()))
            matrix = np.asarray(cov.get("matrix", ()), dtype=np.float64)
            if matrix.shape != (len(names), len(names)) or not np.all(np.isfinite(matrix)):
                raise InputFileError(path, "covariance: matrix must be square, finite, one row per name")
            covariance = (names, matrix)
        sigma0 = _numbers(path, "calibration", data, ("sigma0_px",))["sigma0_px"]
        return StereoCalibration(left, right, tuple(labels), tuple(poses), relative, str(data.get("phase")),
                                 sigma0, parameters, covariance, dict(data.get("statistics") or {}),
                                 dict(data.get("source") or {}))
    except InputFileError:
        raise
    except (UsvipsError, TypeError, ValueError) as error:
        raise InputFileError(path, str(error)) from None


def load_calibration(path: str | Path) -> StereoCalibration:
    """Read a calibration file; raises :class:`InputFileError` naming the file and what is wrong."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(str(path), "no such calibration file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise InputFileError(str(path), f"not valid JSON: {error.msg}", error.lineno) from None
    except UnicodeDecodeError:
        raise InputFileError(str(path), "not a text file") from None
    return calibration_from_dict(data, str(path))


def write_json_atomic(path: str | Path, data: dict) -> None:
    """Write JSON to ``path`` atomically (no partial file on error)."""
    write_text_atomic(path, json.dumps(data, indent=2, allow_nan=False) + "\n")


def save_calibration(calibration: StereoCalibration, path: str | Path) -> None:
    """Write a calibration file atomically."""
    write_json_atomic(path, calibration_to_dict(calibration))
