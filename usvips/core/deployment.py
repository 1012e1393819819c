"""Where and when the imagery was taken: a deployment's metadata (the sample of a stereo-video survey, in
CheckEM's terms) and the georeference of a project's object frame. Plain values, validated; stored by
the project, written out by io (``_Metadata.csv``, georeferenced GeoJSON).

Conventions: latitude and longitude in decimal degrees on WGS 84 (north and east positive); depth in
metres below the sea surface (positive down); heading in degrees clockwise from true north; date as
``YYYY-MM-DD`` and time as ``HH:MM:SS`` (local time of the deployment, as CheckEM expects).

The georeference ties the project's object frame (metres; X and Y horizontal, Z up) to the Earth: its
origin lies at ``latitude``, ``longitude`` and ``depth_m``, and its +X axis points to ``heading_deg``
(so +Y points to ``heading_deg - 90°``: the frame is right-handed with Z up).
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass, fields

import numpy as np

from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.validation import finite_array

#: Deepest point of the ocean, with a margin (m): a depth beyond is a typing error, not a deployment.
MAX_DEPTH_M = 11_500.0


def _text(name: str, value: object) -> str:
    text = "" if value is None else str(value).strip()
    if any(c in text for c in "\t\n\r"):
        raise InvalidParameterError(name, "must be one line without tabs (the exported tables are tab separated)")
    return text


def _optional_number(name: str, value: object, low: float, high: float, unit: str) -> float | None:
    if value is None or (isinstance(value, str) and not value.strip()):
        return None
    if isinstance(value, bool):
        raise InvalidParameterError(name, f"must be a number of {unit}, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(name, f"must be a number of {unit}, got {str(value)[:40]!r}") from None
    if not math.isfinite(number) or not low <= number <= high:
        raise InvalidParameterError(name, f"must be between {low:g} and {high:g} {unit}, got {number:g}")
    return number


def _flag(name: str, value: object) -> bool:
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("yes", "y", "true", "1"):
        return True
    if text in ("no", "n", "false", "0"):
        return False
    raise InvalidParameterError(name, f"must be yes or no, got {str(value)[:40]!r}")


def _is_clock(text: str) -> bool:
    parts = text.split(":")
    if len(parts) not in (2, 3) or not all(p.isdigit() and len(p) <= 2 for p in parts):
        return False
    try:
        _dt.time(*(int(p) for p in parts))
    except ValueError:
        return False
    return True


@dataclass(frozen=True)
class Deployment:
    """One deployment (a BRUV drop, a diver transect): ``opcode`` (its sample id; required), ``date``
    (YYYY-MM-DD) and ``time`` (HH:MM or HH:MM:SS), position (``latitude``, ``longitude``: degrees) and
    ``depth_m`` (m, positive down), ``site``, ``location``, ``status`` (e.g. Fished / No-take),
    whether it was ``successful_count`` and ``successful_length`` (usable for counts and for lengths), the
    ``observer`` and a ``comment``."""

    opcode: str
    date: str = ""
    time: str = ""
    latitude: float | None = None
    longitude: float | None = None
    depth_m: float | None = None
    site: str = ""
    location: str = ""
    status: str = ""
    successful_count: bool = True
    successful_length: bool = True
    observer: str = ""
    comment: str = ""

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.type == "str":
                object.__setattr__(self, f.name, _text(f.name, getattr(self, f.name)))
        if not self.opcode:
            raise InvalidParameterError("opcode", "must not be empty (it is the sample id of every exported row)")
        if self.date:
            try:
                _dt.date.fromisoformat(self.date)
            except ValueError:
                raise InvalidParameterError("date", f"must be a date YYYY-MM-DD, got {self.date[:40]!r}") from None
        if self.time and not _is_clock(self.time):
            raise InvalidParameterError("time", f"must be a time HH:MM or HH:MM:SS, got {self.time[:40]!r}")
        object.__setattr__(self, "latitude", _optional_number("latitude", self.latitude, -90, 90, "degrees"))
        object.__setattr__(self, "longitude", _optional_number("longitude", self.longitude, -180, 180, "degrees"))
        object.__setattr__(self, "depth_m", _optional_number("depth", self.depth_m, 0, MAX_DEPTH_M, "metres"))
        for name in ("successful_count", "successful_length"):
            object.__setattr__(self, name, _flag(name, getattr(self, name)))

    @property
    def clock(self) -> str:
        """The time as HH:MM:SS (seconds added when not given); empty when unknown."""
        if not self.time:
            return ""
        parts = [int(p) for p in self.time.split(":")] + [0]
        return "{:02d}:{:02d}:{:02d}".format(*parts[:3])


#: Field names of :class:`Deployment` in order (the store's columns and the command line's options).
DEPLOYMENT_FIELDS = tuple(f.name for f in fields(Deployment))


@dataclass(frozen=True)
class Georeference:
    """The object frame on the Earth: its origin's ``latitude`` and ``longitude`` (degrees, WGS 84) and
    ``depth_m`` (m below the surface), and ``heading_deg``, the direction of its +X axis (degrees
    clockwise from true north, 0 ≤ heading < 360). Z is up."""

    latitude: float
    longitude: float
    depth_m: float = 0.0
    heading_deg: float = 0.0

    def __post_init__(self) -> None:
        for attribute, low, high, unit in (("latitude", -90, 90, "degrees"), ("longitude", -180, 180, "degrees"),
                                           ("depth_m", 0, MAX_DEPTH_M, "metres")):
            name = "origin " + attribute.removesuffix("_m")  # not the deployment's own latitude, …
            value = _optional_number(name, getattr(self, attribute), low, high, unit)
            if value is None:
                raise InvalidParameterError(name, "is required for a georeference")
            object.__setattr__(self, attribute, value)
        heading = _optional_number("heading", self.heading_deg, -360, 360, "degrees")
        object.__setattr__(self, "heading_deg", 0.0 if heading is None else heading % 360.0)


@dataclass(frozen=True)
class FrameFit:
    """The object frame fitted to points known in both frames: the heading (degrees clockwise from north
    of +X), the origin in the local east/north (m) of the reference the east/north were given in, the
    origin's depth (m), the RMS of the horizontal and depth residuals (m) and the scale a similarity would
    have used (1 for a metric frame; far from 1 means the points do not match)."""

    heading_deg: float
    origin_en: tuple[float, float]
    depth_m: float
    rms_horizontal_m: float
    rms_depth_m: float
    scale: float


def fit_frame_to_east_north(object_xyz, east_north, depths) -> FrameFit:
    """Heading and origin of the object frame from N ≥ 2 points with object-frame coordinates (N, 3) m
    (Z up), local east/north (N, 2) m and depths (N,) m: the least-squares rotation + translation of the
    horizontal coordinates (Umeyama; the object frame is metric, so no scale is fitted — the scale a
    similarity transform would take is reported as a check) and the origin depth as the mean of depth + Z.
    Points that do not span a horizontal direction are a :class:`DegenerateGeometryError`."""
    xyz = finite_array("object points", object_xyz, 3)
    en = finite_array("east/north", east_north, 2)
    depth = np.asarray(depths, dtype=np.float64).reshape(-1)
    if not (len(xyz) == len(en) == len(depth)):
        raise InvalidParameterError("points", f"{len(xyz)} object points, {len(en)} east/north, {len(depth)} depths")
    if len(xyz) < 2:
        raise InvalidParameterError("points", f"need at least 2 points known in both frames, got {len(xyz)}")
    if not np.all(np.isfinite(depth)):
        raise InvalidParameterError("depth", "must be finite numbers")
    a = xyz[:, :2] - xyz[:, :2].mean(axis=0)
    b = en - en.mean(axis=0)
    spread = np.sqrt((a ** 2).sum(axis=1).mean())
    if spread < 1e-6 * max(1.0, float(np.abs(xyz[:, :2]).max())):
        raise DegenerateGeometryError("the points known in both frames are at one horizontal position: the "
                                      "heading cannot be found")
    # the rotation R (object XY → east/north) maximising trace(Rᵀ Σ bᵢ aᵢᵀ), proper (det +1)
    cross = b.T @ a
    u, s, vt = np.linalg.svd(cross)
    d = np.diag([1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    rotation = u @ d @ vt
    origin = en.mean(axis=0) - rotation @ xyz[:, :2].mean(axis=0)
    residual = en - (xyz[:, :2] @ rotation.T + origin)
    # +X goes to rotation[:, 0] = (east, north) = (sin h, cos h)
    heading = float(np.degrees(np.arctan2(rotation[0, 0], rotation[1, 0])) % 360.0)
    origin_depth = depth + xyz[:, 2]
    scale = float((s * np.diag(d)).sum() / (a ** 2).sum())
    return FrameFit(heading, (float(origin[0]), float(origin[1])), float(origin_depth.mean()),
                    float(np.sqrt((residual ** 2).sum(axis=1).mean())),
                    float(np.sqrt(((origin_depth - origin_depth.mean()) ** 2).mean())), scale)
