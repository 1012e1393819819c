"""Housings: an ordered stack of refracting surfaces and the media between them, and the base of every
housing kind.

A housing is held in its camera's own frame (the image frame of ``interior.py``: origin at the
perspective centre, x̄ right, ȳ up, the camera looking along −z̄; metres), so that it moves with the
camera from station to station. ``indices[0]`` is the medium around the lens (air, n1), ``indices[i+1]``
the medium after crossing ``surfaces[i]``; the last is the water (n3).

A housing *kind* (air, flat port, dome cover, dome port, ...) is one subclass of :class:`Housing` in one
module of ``usvips.core.housing.kinds``; defining the class with a ``kind`` name registers it
(``registry.py``). The class owns its surfaces, its parameters (names, units, meanings, default start
values and priors, physical bounds: :class:`~usvips.core.housing.parameter.HousingParameter`), which states
are physical (its constructor raises :class:`InvalidParameterError` naming the parameter), the start grid
of the calibration, how the calibration's named parameters build the left and right housings
(:meth:`Housing.build`), and its (de)serialisation to the calibration file and scene dicts
(:meth:`Housing.to_values` / :meth:`Housing.from_values`). Nothing else names a kind.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, fields, is_dataclass
from functools import cached_property
from typing import ClassVar

import numpy as np

from usvips.core import validation
from usvips.core.errors import InvalidParameterError
from usvips.core.housing.parameter import HousingParameter
from usvips.core.kind_modules import KindTable
from usvips.core.rays import RayBundle, RayStatus
from usvips.core.surfaces import Plane, Sphere, Surface, _dot, refract_with_derivatives

#: Housing geometry a user may know from the housing or the tank (metres, or a refractive index): the port's
#: or tank wall's inner face in front of the camera, the glass thickness, the glass's and the water's indices.
GEOMETRY = {"distance": "distance of the port's or tank wall's inner face in front of the camera (m)",
            "thickness": "glass thickness (m)", "n_glass": "refractive index of the glass",
            "n_water": "refractive index of the water"}


#: the housing kinds by name, filled as each kind's class is defined (a kind module of ``kinds/``, or any
#: subclass that names its ``kind``); :mod:`usvips.core.housing.registry` answers from it
KINDS: KindTable[Housing] = KindTable(__package__, "housing")


class Housing:
    """An ordered stack of surfaces and media in the camera frame (base of every housing).

    Kind-level attributes a registered kind sets (class attributes):

    * ``kind``: its name (``flat-port``); ``order``: where it sorts in lists; ``description``: one line;
    * ``specs``: a :class:`HousingParameter` per symbol (unit, meaning, start, prior sigma, bounds);
    * ``calibration_names``: the names the calibration estimates, ``_l``/``_r`` for one camera's, none for
      both cameras' (shared); ``affects_both``: names with a side suffix that still move both cameras;
    * ``right_follows_rig``: the right housing moves with the rig's relative orientation (a shared cover);
    * ``start_grid``: symbol → start values tried for the least observable parameters;
    * ``report_note``: what the calibration report says about this kind's parameters;
    * ``geometry``: the housing geometry a user may know (:data:`GEOMETRY`: ``distance`` of the port or tank
      wall, glass ``thickness``, ``n_glass``, ``n_water``) → the symbol that holds it in this kind.
    """

    kind: ClassVar[str] = "general"
    order: ClassVar[int] = 100
    description: ClassVar[str] = "any ordered stack of surfaces"
    specs: ClassVar[tuple[HousingParameter, ...]] = ()
    calibration_names: ClassVar[tuple[str, ...]] = ()
    affects_both: ClassVar[frozenset[str]] = frozenset()
    right_follows_rig: ClassVar[bool] = False
    start_grid: ClassVar[dict[str, tuple[float, ...]]] = {}
    report_note: ClassVar[str] = ""
    geometry: ClassVar[dict[str, str]] = {}

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "kind" in cls.__dict__:
            KINDS.add(cls.__dict__["kind"], cls)

    # ---------------------------------------------------------------- the kind's parameters
    @classmethod
    def spec(cls, symbol: str) -> HousingParameter:
        """The parameter called ``symbol`` (``t``, ``dx`` ...) of this kind."""
        for spec in cls.specs:
            if spec.symbol == symbol:
                return spec
        raise InvalidParameterError(symbol, f"is not a parameter of the {cls.kind} housing; parameters: "
                                    f"{', '.join(s.symbol for s in cls.specs) or 'none'}")

    @classmethod
    def priors(cls) -> dict[str, tuple[float, float | None]]:
        """symbol → (start value, prior sigma or None for fixed): the calibration's defaults."""
        return {s.symbol: (s.start, s.sigma) for s in cls.specs}

    @classmethod
    def side_of(cls, name: str) -> str | None:
        """The camera (``l``/``r``) a calibration parameter of this kind moves alone, or None for both."""
        if name in cls.affects_both:
            return None
        for side in ("l", "r"):
            if name.endswith(f"_{side}"):
                return side
        return None

    @classmethod
    def build(cls, values: dict[str, float], rotation: np.ndarray,
              translation: np.ndarray) -> tuple[Housing, Housing]:
        """Left and right housings (each in its camera frame) from the calibration's named values.

        ``rotation``, ``translation`` map left-camera points into the right camera's frame
        (p_r = rotation · p_l + translation) for kinds whose housing is shared by the rig. The default:
        each field of the class is the camera's ``<field>_<side>`` value, or the shared ``<field>``."""
        out = []
        for side in ("l", "r"):
            kwargs = {}
            for name in cls.field_names():
                for key in (f"{name}_{side}", name):
                    if key in values:
                        kwargs[name] = values[key]
                        break
            out.append(cls(**kwargs))
        return out[0], out[1]

    @classmethod
    def calibration_values(cls, left: Housing, right: Housing, rotation: np.ndarray,
                           translation: np.ndarray) -> dict[str, float]:
        """The calibration's named values of a left and right housing (the inverse of :meth:`build`)."""
        out = {}
        for name in cls.calibration_names:
            base, _, side = name.rpartition("_")
            if side in ("l", "r") and base:
                out[name] = float(getattr(left if side == "l" else right, base))
            else:
                out[name] = float(getattr(left, name))
        return out

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """The constructor's parameters (the file's and scene's keys)."""
        return tuple(f.name for f in fields(cls)) if is_dataclass(cls) else ()

    @classmethod
    def from_values(cls, values: dict[str, float]) -> Housing:
        """A housing from its file or scene dict (the keys of :meth:`to_values`); an unknown or missing
        key is an :class:`InvalidParameterError` naming it."""
        known = cls.field_names()
        unknown = [k for k in values if k not in known]
        if unknown:
            raise InvalidParameterError(unknown[0], f"is not a parameter of the {cls.kind} housing; parameters: "
                                        f"{', '.join(known) or 'none'}")
        required = [f.name for f in fields(cls) if f.default is MISSING] if is_dataclass(cls) else []
        missing = [k for k in required if k not in values]
        if missing:
            raise InvalidParameterError(missing[0], f"missing: the {cls.kind} housing needs {', '.join(required)}")
        return cls(**values)

    def to_values(self) -> dict[str, float]:
        """The file's and scene's dict of this housing: :meth:`parameters`, and n1 when it is not air's 1."""
        values = self.parameters()
        n1 = getattr(self, "n1", 1.0)
        if n1 != 1.0:
            values["n1"] = n1
        return values

    @classmethod
    def from_symbols(cls, values: dict[str, float] | None = None) -> Housing:
        """One camera's housing from symbol values, the rest at their defaults (a rig on paper, tests)."""
        chosen = {s.symbol: s.start for s in cls.specs} | dict(values or {})
        return cls.from_values({k: v for k, v in chosen.items() if k in cls.field_names()})

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


def shared_plane_in_camera(d: float, e: float, g: float, rotation: np.ndarray,
                           translation: np.ndarray) -> tuple[float, float, float]:
    """(d, e, g) of a plane given in one frame (e.g. the rig's, the left camera's) in another frame.

    ``rotation`` and ``translation`` map points of the first frame into the second:
    p_second = rotation · p_first + translation. Used for System I's cover plane shared by both cameras.
    """
    plane = Plane.from_coefficients(d, e, g).transformed(np.asarray(rotation, float), np.asarray(translation, float))
    return plane_coefficients(plane)
