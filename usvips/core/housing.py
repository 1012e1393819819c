"""Housings: an ordered stack of refracting surfaces and the media between them.

A housing is held in its camera's own frame (the image frame of ``interior.py``: origin at the
perspective centre, x̄ right, ȳ up, the camera looking along −z̄; metres), so that it moves with the
camera from station to station. ``indices[0]`` is the medium around the lens (air, n1), ``indices[i+1]``
the medium after crossing ``surfaces[i]``; the last is the water (n3).

The two housings of the seeds are instances of the general stack:

* :class:`DomeCoverHousing` (System I, thesis 2.2.4): a concave spherical inner cover surface
  |p − (a, b, c)| = r, then a plane outer surface d·x + e·y + z + g = 0, glass (n2) between, water (n3)
  outside. The thesis's rig has one cover plane for both cameras; each camera's housing holds that
  plane expressed in its own frame (see :func:`shared_plane_in_camera`).
* :class:`FlatPortHousing` (System II, 1997 paper V.C): a flat glass port per camera, inner face
  d·x + e·y + z + g = 0 and the outer face parallel to it, ``t`` metres further from the camera.

In the camera frame a port straight ahead of the camera at distance D has d = e = 0 and g = D > 0.
The seeds print (a, b, c) and (d, e, g) in object space for one station: convert with
:func:`dome_cover_from_object_space` / :func:`flat_port_from_object_space`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from usvips.core import validation
from usvips.core.errors import InvalidParameterError
from usvips.core.rays import RayBundle, RayStatus
from usvips.core.surfaces import Plane, Sphere, Surface, _dot, refract_with_derivatives


class Housing:
    """An ordered stack of surfaces and media in the camera frame (base of every housing)."""

    kind = "general"

    @property
    def surfaces(self) -> tuple[Surface, ...]:
        raise AttributeError("a housing must define its surfaces")

    @property
    def indices(self) -> tuple[float, ...]:
        raise AttributeError("a housing must define its refractive indices")

    def parameters(self) -> dict[str, float]:
        """Named parameters (seeds' symbols, camera frame, metres) of a parametric housing."""
        return {}

    def trace(self, origins: np.ndarray, directions: np.ndarray) -> RayBundle:
        """Trace rays (N, 3) from inside the housing (air) out into the water.

        Returns the rays in the outer medium: origin at the last crossing, unit direction after the last
        refraction, a status per ray and, for failed rays, the index of the surface at fault. Rays are
        vectorised; a failed ray keeps the finite state it had when it stopped.
        """
        return self.trace_with_tangents(origins, directions)[0]

    def trace_with_tangents(self, origins: np.ndarray, directions: np.ndarray,
                            tangents: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
                            ) -> tuple[RayBundle, list[tuple[np.ndarray, np.ndarray]]]:
        """:meth:`trace`, and carry first derivatives along (forward-mode differentiation).

        ``tangents`` holds, per differentiation variable, the derivatives (dorigins, ddirections), each
        (N, 3), of the starting rays (directions need not be unit: the derivative of normalising them
        is included). Returns the bundle and the derivatives of its origins and unit directions.
        """
        origins = np.array(origins, dtype=np.float64, copy=True)
        directions = np.array(directions, dtype=np.float64, copy=True)
        length = np.sqrt(_dot(directions, directions))[:, None]
        directions /= length
        carried = []
        for d_origin, d_direction in tangents:
            d_direction = d_direction / length
            d_direction = d_direction - _dot(d_direction, directions)[:, None] * directions
            carried.append((np.array(d_origin, dtype=np.float64), d_direction))
        n = origins.shape[0]
        status = np.zeros(n, dtype=np.uint8)
        failed_surface = np.full(n, -1, dtype=np.int16)
        indices = self.indices
        for k, surface in enumerate(self.surfaces):
            t, hit = surface.intersect(origins, directions)
            points = origins + t[:, None] * directions
            normals = surface.normals(points)
            point_derivatives = []
            if carried:
                slope = _safe(_dot(normals, directions))
                for d_origin, d_direction in carried:
                    d_t = -(_dot(normals, d_origin) + t * _dot(normals, d_direction)) / slope
                    d_points = d_origin + d_t[:, None] * directions + t[:, None] * d_direction
                    point_derivatives.append((d_points, d_direction,
                                              surface.normal_derivative(points, normals, d_points)))
            new_d, tir, direction_derivatives = refract_with_derivatives(
                directions, normals, indices[k], indices[k + 1], tuple((dd, dn) for _, dd, dn in point_derivatives))
            good = hit & ~tir & (status == RayStatus.OK)
            all_good = bool(good.all())
            if not all_good:
                fresh = status == RayStatus.OK
                status[fresh & ~hit] = RayStatus.MISSED_SURFACE
                status[fresh & hit & tir] = RayStatus.TOTAL_INTERNAL_REFLECTION
                failed_surface[fresh & ~good] = k
            updated = []
            for (d_origin, d_direction), (d_points, _, _), d_new in zip(carried, point_derivatives,
                                                                         direction_derivatives, strict=True):
                if not all_good:
                    d_points = np.where(good[:, None], d_points, d_origin)
                    d_new = np.where(good[:, None], d_new, d_direction)
                updated.append((d_points, d_new))
            carried = updated
            if all_good:
                origins, directions = points, new_d
            else:
                origins = np.where(good[:, None], points, origins)
                directions = np.where(good[:, None], new_d, directions)
        return RayBundle(origins, directions, status, failed_surface), carried

    @cached_property
    def axis(self) -> np.ndarray | None:
        """The unit symmetry axis through the perspective centre, pointing out of the camera, or None.

        A housing is axial when every surface is rotationally symmetric about one line through the
        perspective centre: planes whose normals are parallel, spheres whose centres lie on that line.
        Back-projection through an axial housing is a 1-D problem in the plane of refraction.
        """
        surfaces = self.surfaces
        if not surfaces:
            return np.array([0.0, 0.0, -1.0])
        axis = None
        for surface in surfaces:
            if isinstance(surface, Plane):
                candidate = surface.normal
            elif isinstance(surface, Sphere):
                length = float(np.linalg.norm(surface.center))
                if length < 1e-12:
                    continue  # a sphere centred on the perspective centre bends no ray from it
                candidate = surface.center / length
            else:
                return None
            if candidate[2] > 0:
                candidate = -candidate
            if axis is None:
                axis = candidate
            elif np.linalg.norm(np.cross(axis, candidate)) > 1e-12:
                return None
        return axis if axis is not None else np.array([0.0, 0.0, -1.0])

    @cached_property
    def is_planar_stack(self) -> bool:
        """True when every surface is a plane and all are parallel (a flat port of any thickness)."""
        return bool(self.surfaces) and all(isinstance(s, Plane) for s in self.surfaces) and \
            self.axis is not None

    @property
    def is_refractive(self) -> bool:
        return any(abs(a - b) > 0 for a, b in zip(self.indices[:-1], self.indices[1:], strict=True))

    def __repr__(self) -> str:
        params = ", ".join(f"{k}={v:.6g}" for k, v in self.parameters().items())
        return f"{type(self).__name__}({params})"


def _safe(values: np.ndarray) -> np.ndarray:
    return np.where(np.abs(values) > 1e-300, values, 1e-300)


def _index(name: str, value: float) -> float:
    return validation.positive(name, value)


@dataclass(frozen=True, repr=False)
class GeneralHousing(Housing):
    """Any ordered stack: ``surfaces`` and ``indices`` (one more index than surfaces)."""

    surface_stack: tuple[Surface, ...]
    index_stack: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.index_stack) != len(self.surface_stack) + 1:
            raise InvalidParameterError(
                "indices", f"need {len(self.surface_stack) + 1} refractive indices for "
                f"{len(self.surface_stack)} surfaces, got {len(self.index_stack)}")
        object.__setattr__(self, "index_stack",
                           tuple(_index(f"n{i + 1}", n) for i, n in enumerate(self.index_stack)))
        object.__setattr__(self, "surface_stack", tuple(self.surface_stack))

    @property
    def surfaces(self) -> tuple[Surface, ...]:
        return self.surface_stack

    @property
    def indices(self) -> tuple[float, ...]:
        return self.index_stack


@dataclass(frozen=True, repr=False)
class AirHousing(Housing):
    """No housing: the camera in air (the pinhole model with distortion)."""

    kind = "air"

    @property
    def surfaces(self) -> tuple[Surface, ...]:
        return ()

    @property
    def indices(self) -> tuple[float, ...]:
        return (1.0,)


@dataclass(frozen=True, repr=False)
class DomeCoverHousing(Housing):
    """System I: concave sphere (a, b, c, r) then cover plane (d, e, g), camera frame, metres.

    n1 (inside, air), n2 (glass), n3 (water) are refractive indices.
    """

    a: float
    b: float
    c: float
    r: float
    d: float
    e: float
    g: float
    n2: float = 1.6
    n3: float = 1.34
    n1: float = 1.0

    kind = "dome-cover"

    def __post_init__(self) -> None:
        for name in ("a", "b", "c", "d", "e", "g"):
            object.__setattr__(self, name, validation.finite(name, getattr(self, name)))
        object.__setattr__(self, "r", validation.positive("r", self.r))
        for name in ("n1", "n2", "n3"):
            object.__setattr__(self, name, _index(name, getattr(self, name)))
        if np.linalg.norm([self.a, self.b, self.c]) >= self.r:
            raise InvalidParameterError(
                "r", f"the perspective centre must lie inside the cover sphere: |(a, b, c)| = "
                f"{np.linalg.norm([self.a, self.b, self.c]):.4g} m >= r = {self.r:.4g} m")
        if self.g <= 0:
            raise InvalidParameterError("g", f"the cover plane must be in front of the camera (g > 0), got {self.g:g}")
        clearance = (self.d * self.a + self.e * self.b + self.c + self.g) / np.sqrt(self.d**2 + self.e**2 + 1.0)
        if clearance < self.r:
            raise InvalidParameterError(
                "g", f"the cover plane cuts the cover sphere (the sphere centre is {clearance:.4g} m from the plane, "
                f"less than r = {self.r:.4g} m): the glass would have no thickness somewhere")

    @cached_property
    def surfaces(self) -> tuple[Surface, ...]:
        return (Sphere(np.array([self.a, self.b, self.c]), self.r), Plane.from_coefficients(self.d, self.e, self.g))

    @property
    def indices(self) -> tuple[float, ...]:
        return (self.n1, self.n2, self.n3)

    def parameters(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in ("a", "b", "c", "r", "d", "e", "g", "n2", "n3")}


@dataclass(frozen=True, repr=False)
class FlatPortHousing(Housing):
    """System II: a flat glass port, inner face d·x + e·y + z + g = 0 (camera frame), thickness t.

    g: distance-like offset (metres; g > 0 puts the port in front of the camera), t: glass thickness
    (metres), n1 (air), n2 (glass), n3 (water).
    """

    d: float
    e: float
    g: float
    t: float
    n2: float = 1.5
    n3: float = 1.34
    n1: float = 1.0

    kind = "flat-port"

    def __post_init__(self) -> None:
        for name in ("d", "e", "g"):
            object.__setattr__(self, name, validation.finite(name, getattr(self, name)))
        object.__setattr__(self, "t", validation.positive("t", self.t))
        for name in ("n1", "n2", "n3"):
            object.__setattr__(self, name, _index(name, getattr(self, name)))
        if self.g <= 0:
            raise InvalidParameterError("g", f"the port must be in front of the camera (g > 0), got {self.g:g}")

    @cached_property
    def surfaces(self) -> tuple[Surface, ...]:
        inner = Plane.from_coefficients(self.d, self.e, self.g)
        # the outer face is the inner one moved t further along the viewing direction (−normal side)
        outer = Plane(inner.normal, inner.offset + self.t)
        return (inner, outer)

    @property
    def indices(self) -> tuple[float, ...]:
        return (self.n1, self.n2, self.n3)

    def parameters(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in ("d", "e", "g", "t", "n2", "n3")}

    @cached_property
    def axis(self) -> np.ndarray:
        """A flat port is always axial: the port normal through the perspective centre, outwards."""
        normal = np.array([self.d, self.e, 1.0]) / np.sqrt(self.d**2 + self.e**2 + 1.0)
        return -normal

    @property
    def is_planar_stack(self) -> bool:
        return True


# --- conversions between the seeds' object-space parameters and the camera frame ----------------------

def _to_camera(rotation: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, T) such that p_camera = R · p_object + T, for an object → image rotation M and centre X0."""
    return rotation, -rotation @ position


def plane_coefficients(plane: Plane) -> tuple[float, float, float]:
    """(d, e, g) of a plane, scaled so that its z coefficient is 1 (raises if the plane contains z)."""
    nz = plane.normal[2]
    if abs(nz) < 1e-9:
        raise InvalidParameterError("plane", "is parallel to the z axis and has no (d, e, g) form")
    return float(plane.normal[0] / nz), float(plane.normal[1] / nz), float(plane.offset / nz)


def dome_cover_from_object_space(a: float, b: float, c: float, r: float, d: float, e: float, g: float,
                                 n2: float, n3: float, rotation: np.ndarray, position: np.ndarray,
                                 n1: float = 1.0) -> DomeCoverHousing:
    """System I housing in the camera frame from the seeds' object-space (a, b, c, r, d, e, g).

    ``rotation`` is the camera's M (object → image), ``position`` its perspective centre (X0, Y0, Z0).
    """
    rot, shift = _to_camera(np.asarray(rotation, float), np.asarray(position, float))
    center = rot @ np.array([a, b, c], dtype=float) + shift
    dc, ec, gc = plane_coefficients(Plane.from_coefficients(d, e, g).transformed(rot, shift))
    return DomeCoverHousing(*center, r, dc, ec, gc, n2=n2, n3=n3, n1=n1)


def flat_port_from_object_space(d: float, e: float, g: float, t: float, n2: float, n3: float,
                                rotation: np.ndarray, position: np.ndarray,
                                n1: float = 1.0) -> FlatPortHousing:
    """System II housing in the camera frame from the seeds' object-space plane (d, e, g)."""
    rot, shift = _to_camera(np.asarray(rotation, float), np.asarray(position, float))
    dc, ec, gc = plane_coefficients(Plane.from_coefficients(d, e, g).transformed(rot, shift))
    return FlatPortHousing(dc, ec, gc, t, n2=n2, n3=n3, n1=n1)


def shared_plane_in_camera(d: float, e: float, g: float, rotation: np.ndarray,
                           translation: np.ndarray) -> tuple[float, float, float]:
    """(d, e, g) of a plane given in one frame (e.g. the rig's, the left camera's) in another frame.

    ``rotation`` and ``translation`` map points of the first frame into the second:
    p_second = rotation · p_first + translation. Used for System I's cover plane shared by both cameras.
    """
    plane = Plane.from_coefficients(d, e, g).transformed(np.asarray(rotation, float), np.asarray(translation, float))
    return plane_coefficients(plane)
