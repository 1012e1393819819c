"""Object-frame metres to WGS 84 through a project's georeference (:class:`usvips.core.deployment.Georeference`),
with PROJ (pyproj) rather than hand-written geodesy.

The object frame (X, Y horizontal, Z up; metres) is turned by the heading into local east and north
(+X points to ``heading_deg`` clockwise from north), and PROJ's exact topocentric conversion around the
point of the WGS 84 ellipsoid above the origin (``+proj=topocentric``, inverse) places (east, north, 0)
on the ellipsoid: geodetic longitude and latitude (degrees). The height written is Z − ``depth_m`` (m up
from the sea surface, which is taken as the ellipsoid: the survey's depth datum, not a geoid model).

So the map shows each point straight above it in the object frame (along the origin's vertical), at the
sea surface's scale: lengths and areas measured on the map (on the ellipsoid) equal the horizontal metres
of the project, to (distance / Earth radius)² (1e-9 at 200 m). Placing points along their own normals at
their depth would stretch them on the map by depth / R (2 ppm at 12 m) for positions that differ by
micrometres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pyproj import Geod, Transformer

from usvips.core.deployment import FrameFit, Georeference, fit_frame_to_east_north
from usvips.core.errors import DegenerateGeometryError, InputFileError, InvalidParameterError
from usvips.core.observations import ControlPoints


def object_to_enu(georeference: Georeference, points: np.ndarray) -> np.ndarray:
    """East, north, up (N, 3) m around the origin of object-frame points (N, 3) m (up = Z)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    heading = np.radians(georeference.heading_deg)
    s, c = np.sin(heading), np.cos(heading)
    east = points[:, 0] * s - points[:, 1] * c
    north = points[:, 0] * c + points[:, 1] * s
    return np.column_stack([east, north, points[:, 2]])


def _transformer(georeference: Georeference) -> Transformer:
    g = georeference
    return Transformer.from_pipeline(
        "+proj=pipeline "
        f"+step +inv +proj=topocentric +ellps=WGS84 +lat_0={float(g.latitude)!r} +lon_0={float(g.longitude)!r} +h_0=0 "
        "+step +inv +proj=cart +ellps=WGS84 "
        "+step +proj=unitconvert +xy_in=rad +xy_out=deg")


def object_to_geographic(georeference: Georeference, points: np.ndarray) -> np.ndarray:
    """Longitude, latitude (degrees, WGS 84) and height (m: up from the sea surface, so −depth) (N, 3) of
    object-frame points (N, 3) m. A point the conversion cannot place (non-finite result) is a
    :class:`DegenerateGeometryError`."""
    enu = object_to_enu(georeference, points)
    lon, lat, _ = _transformer(georeference).transform(enu[:, 0], enu[:, 1], np.zeros(len(enu)))
    out = np.column_stack([np.atleast_1d(lon), np.atleast_1d(lat), enu[:, 2] - georeference.depth_m])
    if not np.all(np.isfinite(out)):
        raise DegenerateGeometryError("the georeference cannot place these points on the Earth")
    return out


def _topocentric(latitude: float, longitude: float) -> Transformer:
    """Geodetic (lon, lat in degrees, height m) → east, north, up (m) around a point of the ellipsoid."""
    return Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad +step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={float(latitude)!r} +lon_0={float(longitude)!r} +h_0=0")


def georeference_from_points(control: ControlPoints, geographic: dict[str, tuple[float, float, float]]
                             ) -> tuple[Georeference, FrameFit, list[str]]:
    """The georeference of the object frame from control points with geographic coordinates: ``control``
    (object frame, m, Z up) and ``geographic`` id → (latitude, longitude in degrees WGS 84, depth m) of
    the same points. Their east/north around the first one (at the surface, as :func:`object_to_geographic`
    places points) are fitted by :func:`usvips.core.deployment.fit_frame_to_east_north`; returns the
    georeference, the fit (residual RMS, scale) and the ids used. Ids in only one of the two are left out;
    fewer than two in both is an :class:`InvalidParameterError`."""
    ids = [pid for pid in control.ids if pid in geographic]
    if len(ids) < 2:
        raise InvalidParameterError("geographic points", f"{len(ids)} of their ids are control points of the "
                                    "project; at least 2 are needed")
    index = {pid: i for i, pid in enumerate(control.ids)}
    xyz = control.xyz[[index[pid] for pid in ids]]
    geo = np.array([geographic[pid] for pid in ids], dtype=np.float64)
    # east/north around the first point, then around the fitted origin (a heading is measured from north
    # at the origin: meridians converge, 4e-4° over 20 m at 66° latitude), until the origin stays put
    lat, lon = float(geo[0, 0]), float(geo[0, 1])  # plain floats: PROJ reads their repr
    for _ in range(4):
        east, north, _ = _topocentric(lat, lon).transform(geo[:, 1], geo[:, 0], np.zeros(len(geo)))
        fit = fit_frame_to_east_north(xyz, np.column_stack([east, north]), geo[:, 2])
        to_geographic = Transformer.from_pipeline(
            "+proj=pipeline "
            f"+step +inv +proj=topocentric +ellps=WGS84 +lat_0={lat!r} +lon_0={lon!r} +h_0=0 "
            "+step +inv +proj=cart +ellps=WGS84 +step +proj=unitconvert +xy_in=rad +xy_out=deg")
        new_lon, new_lat, _ = (float(v) for v in to_geographic.transform(fit.origin_en[0], fit.origin_en[1], 0.0))
        moved = float(np.hypot(*fit.origin_en))
        lat, lon = new_lat, new_lon
        if moved < 1e-9:
            break
    if fit.depth_m < 0:
        raise InvalidParameterError("geographic points", f"their depths put the object frame's origin "
                                    f"{-fit.depth_m:.3f} m above the surface (depth is positive down, Z up)")
    return Georeference(lat, lon, fit.depth_m, fit.heading_deg), fit, ids


GEOGRAPHIC_COLUMNS = ("id", "latitude", "longitude", "depth")


def read_geographic_points(path: str | Path) -> dict[str, tuple[float, float, float]]:
    """A CSV of points with geographic coordinates: ``id,latitude,longitude,depth`` (degrees WGS 84,
    metres below the surface); errors name the file, line and column."""
    from usvips.io.tables import _check_id, _check_width, _column_index, _number, _rows

    path = Path(path)
    header, rows = _rows(path)
    columns = _column_index(path, header, GEOGRAPHIC_COLUMNS)
    points: dict[str, tuple[float, float, float]] = {}
    for line, fields in rows:
        _check_width(path, line, fields, header)
        pid = _check_id(path, line, fields[columns["id"]])
        if pid in points:
            raise InputFileError(str(path), f"duplicate id {pid[:40]!r}", line)
        lat, lon, depth = (_number(path, line, c, fields[columns[c]]) for c in GEOGRAPHIC_COLUMNS[1:])
        for name, value, low, high in (("latitude", lat, -90, 90), ("longitude", lon, -180, 180),
                                       ("depth", depth, -100, 11_500)):
            if not low <= value <= high:
                raise InputFileError(str(path), f"column {name}: {value:g} is not between {low} and {high}", line)
        points[pid] = (lat, lon, depth)
    return points


_WGS84 = Geod(ellps="WGS84")


def meridian_crossing(start: np.ndarray, end: np.ndarray, meridian: float) -> tuple[float, float]:
    """Where the geodesic from ``start`` to ``end`` (longitude, latitude in degrees, WGS 84; longitudes
    continuous, e.g. 179.9999 and 180.0002) crosses the meridian ``meridian`` (degrees, between them):
    (latitude in degrees, fraction of the geodesic's length from ``start``). A line cut there stays on the
    geodesics a GIS draws and measures between the vertices."""
    azimuth, _, distance = _WGS84.inv(start[0], start[1], end[0], end[1])

    def offset(s: float) -> tuple[float, float]:
        lon, lat, _ = _WGS84.fwd(start[0], start[1], azimuth, s)
        return start[0] + (lon - start[0] + 180.0) % 360.0 - 180.0 - meridian, lat

    low, high = 0.0, distance
    f_low, f_high = start[0] - meridian, end[0] - meridian
    s, latitude = distance * f_low / (f_low - f_high), float(start[1])
    for _ in range(60):  # regula falsi (Illinois): the longitude is nearly linear in s over a short line
        f, latitude = offset(s)
        if abs(f) < 1e-13 or high - low < 1e-9:
            break
        if (f < 0) == (f_low < 0):
            low, f_low, f_high = s, f, f_high / 2
        else:
            high, f_high, f_low = s, f, f_low / 2
        s = low + (high - low) * f_low / (f_low - f_high)
    return float(latitude), (s / distance if distance > 0 else 0.0)
