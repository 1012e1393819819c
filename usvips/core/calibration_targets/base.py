"""A calibration target kind: what it is (its description), where its points are, how it is found.

Each kind is one :class:`CalibrationTarget` subclass in one module of ``kinds/`` (as housings and
measurement kinds are); defining the class with a ``kind`` name registers it. The description of a
target is a small JSON object (``describe()`` / ``from_description()``; :mod:`usvips.io.target_file`
reads and writes the file), validated by the class: a contradictory description raises
:class:`~usvips.core.errors.InvalidParameterError` naming the field.

Conventions: target coordinates in metres in the target's own frame (a board: the plane z = 0);
pixels as everywhere (x right, y down, origin at the centre of the top-left pixel).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from usvips.core.calibration_targets.detection import TargetDetection
from usvips.core.kind_modules import KindTable
from usvips.core.observations import ControlPoints

#: the target kinds by name, filled as each kind's class is defined (a kind module of ``kinds/``, or any
#: subclass that names its ``kind``); :mod:`usvips.core.calibration_targets.registry` answers from it
KINDS: KindTable[CalibrationTarget] = KindTable(__package__, "calibration target")


class CalibrationTarget(ABC):
    """Base of every target kind. Subclasses set ``kind`` (registry name), ``description`` (one line for
    menus and ``--help``) and ``order`` (menu position), and implement the methods below."""

    kind: ClassVar[str] = ""
    description: ClassVar[str] = ""
    order: ClassVar[int] = 100
    #: the target's geometry is exact by construction (a printed board): the calibration does not search
    #: its coordinates for misprints. A surveyed 3-D field is not (its control file may hold a typo).
    exact: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("kind"):
            KINDS.add(cls.__dict__["kind"], cls)

    # -------------------------------------------------------------------------------- description
    @abstractmethod
    def describe(self) -> dict:
        """The JSON-able description (with ``"kind"``) from which :meth:`from_description` rebuilds it."""

    @classmethod
    @abstractmethod
    def from_description(cls, description: dict, source: str = "") -> CalibrationTarget:
        """Build and validate from a description; errors name ``source`` and the field."""

    # -------------------------------------------------------------------------------- geometry
    @abstractmethod
    def control_points(self) -> ControlPoints:
        """Every point of the target: ids and coordinates (metres, target frame)."""

    @property
    def is_planar(self) -> bool:
        """All points in one plane (within a millionth of the target's size)."""
        xyz = self.control_points().xyz
        centred = xyz - xyz.mean(axis=0)
        singular = np.linalg.svd(centred, compute_uv=False)
        return bool(singular[0] == 0 or singular[2] / singular[0] < 1e-6)

    # -------------------------------------------------------------------------------- detection
    @abstractmethod
    def detect(self, image: np.ndarray) -> TargetDetection:
        """Find the target in ``image`` (grey or colour, uint8 or uint16). Never raises for an image in which
        the target is not found: the detection is then falsy with its reason."""
