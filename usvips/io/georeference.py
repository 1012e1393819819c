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

import numpy as np
from pyproj import Transformer

from usvips.core.deployment import Georeference
from usvips.core.errors import DegenerateGeometryError


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
        f"+step +inv +proj=topocentric +ellps=WGS84 +lat_0={g.latitude!r} +lon_0={g.longitude!r} +h_0=0 "
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
