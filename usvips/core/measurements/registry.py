"""The measurement-kind registry: every kind of measured object is one class in one module of
``usvips.core.measurements.kinds``; defining the class registers it, and the registry imports every
module of that package the first time it is asked (nothing lists the kinds by hand).

A kind states its minimum (and maximum) number of vertices, whether its outline closes, how it is
drawn (:data:`DRAWINGS`, a Qt-free word the panes and the exports translate), and its figures: their
names and units and the formula (:meth:`MeasurementKind.values`); the sigmas from the joint (3N, 3N)
covariance of its vertices follow by propagation (first order, and second order where it matters).
An unknown kind is an error, never a default.

Legacy name: projects of schema ≤ 2 and picks CSVs know ``line``: with two vertices it is a
``length``, with more an ``arc`` (:func:`resolve`; the store's migration to schema 3 renames stored rows
the same way).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import numpy as np

from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.kind_modules import KindTable
from usvips.core.measurements.figures import Figure, figures_of

#: How a kind is drawn: a marker per vertex; an open polyline through the vertices; a closed polygon;
#: the fitted circle (its outline, :meth:`MeasurementKind.outline`, sampled in 3-D).
DRAWINGS = ("marker", "polyline", "polygon", "circle")
#: Old kind names → the kind they mean for a number of vertices.
LEGACY = {"line": lambda n: "length" if n == 2 else "arc"}

_TABLE: KindTable[MeasurementKind] = KindTable(__package__, "measurement")
_KINDS = _TABLE.kinds


class UnknownKindError(InvalidParameterError):
    """A measurement kind the registry does not know."""

    def __init__(self, name: object):
        super().__init__("kind", f"unknown measurement kind {name!r}; known: {', '.join(names())}")


class MeasurementKind:
    """Base of the measurement kinds. Subclasses set the class attributes and :meth:`compute`.

    ``figure_names``: (name, unit) of the figures :meth:`compute` returns, the first one the main
    figure unless ``main_figure`` names another (the main figure is shown in the object list, and the
    quality rules' precision/value rule checks it when ``relative_rule``).
    ``eventmeasure``: the EventMeasure-style table its rows go to (``Lengths``, ``3DPoints``, or a table
    of its own such as ``Polygons``).
    """

    name: ClassVar[str]
    order: ClassVar[int] = 100
    description: ClassVar[str]
    minimum_vertices: ClassVar[int]
    maximum_vertices: ClassVar[int | None] = None
    closes: ClassVar[bool] = False
    #: its outline is a curve fitted to the vertices (it overrides :meth:`outline`), not the vertices
    #: themselves: views draw it through :meth:`outline` rather than through the picks
    outline_fitted: ClassVar[bool] = False
    drawing: ClassVar[str]
    figure_names: ClassVar[tuple[tuple[str, str], ...]]
    relative_rule: ClassVar[bool] = True
    main_figure: ClassVar[str | None] = None
    eventmeasure: ClassVar[str]

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "name" not in cls.__dict__:
            return
        if cls.drawing not in DRAWINGS:
            raise TypeError(f"measurement kind {cls.name!r}: drawing must be one of {DRAWINGS}")
        if ("outline" in cls.__dict__) != cls.outline_fitted:
            raise TypeError(f"measurement kind {cls.name!r}: outline_fitted must say whether it overrides outline()")
        if not callable(getattr(cls, "values", None)):
            raise TypeError(f"measurement kind {cls.name!r} defines no values(points), its formula")
        _TABLE.add(cls.name, cls)

    # -------------------------------------------------------------- what each kind supplies
    #: ``values(points)`` (a classmethod every named kind defines): the figures' values (K,), in the order
    #: of ``figure_names``, of vertices (N, 3) m — the kind's formula; degenerate geometry raises
    #: :class:`DegenerateGeometryError`. A named kind without it is refused when it is defined.
    values: ClassVar[Callable[[np.ndarray], np.ndarray]]
    #: ``values_many(stack)`` (optional): :meth:`values` of many vertex sets (M, N, 3) at once, (M, K) — the
    #: Jacobian's shifted vertices then cost one call (a survey's 10,000 objects' figures, 3× faster)
    values_many: ClassVar[Callable[[np.ndarray], np.ndarray] | None] = None
    #: the figures that are the components of a unit vector without a sign of its own (a circle's normal):
    #: differenced as a direction, not across the flip of its sign convention (:func:`figures_of`)
    axial_figures: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def compute(cls, points: np.ndarray, covariance: np.ndarray,
                pointing: np.ndarray | None = None) -> tuple[Figure, ...]:
        """The figures of vertices (N, 3) m with their joint covariance (3N, 3N) m²: :meth:`values` with
        sigmas, their root mean square errors (one Jacobian by central differences, and the second-order
        part where it matters); with ``pointing``, the pointing part of the covariance, each sigma's
        breakdown too (:func:`figures_of`)."""
        return figures_of(cls.values, cls.figure_names, points, covariance, many=cls.values_many,
                          pointing=pointing, axial=cls.axial_figures)

    @classmethod
    def outline(cls, points: np.ndarray) -> np.ndarray:
        """3-D points (M, 3) m to draw (closed outlines repeat their first point)."""
        return np.vstack([points, points[:1]]) if cls.closes and len(points) > 2 else points

    # -------------------------------------------------------------- shared
    @classmethod
    def main_name(cls) -> str:
        """The main figure's name: ``main_figure``, by default the first of ``figure_names``."""
        return cls.main_figure or cls.figure_names[0][0]

    @classmethod
    def check_count(cls, count: int) -> None:
        """Raise :class:`DegenerateGeometryError` when ``count`` vertices cannot make this kind."""
        a = "an" if cls.name[:1] in "aeiou" else "a"
        if count < cls.minimum_vertices:
            raise DegenerateGeometryError(f"{a} {cls.name} needs at least {cls.minimum_vertices} vertices, "
                                          f"got {count}")
        if cls.maximum_vertices is not None and count > cls.maximum_vertices:
            raise DegenerateGeometryError(f"{a} {cls.name} has at most {cls.maximum_vertices} vertices, got {count}")

    @classmethod
    def figures(cls, points: np.ndarray, covariance: np.ndarray,
                pointing: np.ndarray | None = None) -> tuple[Figure, ...]:
        """Checked vertex count, then :meth:`compute`."""
        cls.check_count(len(points))
        return cls.compute(points, covariance, pointing)


def names() -> tuple[str, ...]:
    """Every registered kind, in the order the kinds ask for (``order``), then by name."""
    return _TABLE.names()


def registered_kinds() -> tuple[type[MeasurementKind], ...]:
    return _TABLE.classes()


def kind(name: str) -> type[MeasurementKind]:
    """The kind called ``name`` (legacy names are not accepted here: see :func:`resolve`)."""
    _TABLE.discover()
    if not isinstance(name, str) or name not in _KINDS:
        raise UnknownKindError(name)
    return _KINDS[name]


def resolve(name: str, vertex_count: int) -> str:
    """The registered kind meant by ``name`` for an object of ``vertex_count`` vertices: the name itself,
    or what a legacy name (``line``) means; anything else is an :class:`UnknownKindError`."""
    if isinstance(name, str) and name in LEGACY:
        name = LEGACY[name](vertex_count)
    return kind(name).name
