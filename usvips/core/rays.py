"""Ray bundles and the per-ray status that says why a ray or a projection failed.

Failed rows never carry NaN: a ray that misses a surface or reflects totally keeps the finite origin and
direction it had when it stopped, and its ``status`` says what happened and ``failed_surface`` where.
Always look at ``ok`` (or call ``require_ok``) before using the numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from usvips.core.errors import DegenerateGeometryError


class RayStatus(IntEnum):
    """Why a ray, a projection or an intersection has no valid result (0 = valid)."""

    OK = 0
    MISSED_SURFACE = 1
    TOTAL_INTERNAL_REFLECTION = 2
    BEHIND_CAMERA = 3
    NOT_CONVERGED = 4
    OUTSIDE_FRAME = 5
    PARALLEL_RAYS = 6
    FAILED_RAY = 7
    DIVERGING_RAYS = 8
    DISTORTION_FOLDS = 9

    @property
    def reason(self) -> str:
        return _REASONS[self]


_REASONS = {
    RayStatus.OK: "valid",
    RayStatus.MISSED_SURFACE: "the ray misses a cover surface of the housing",
    RayStatus.TOTAL_INTERNAL_REFLECTION: "the ray is totally reflected at a cover surface",
    RayStatus.BEHIND_CAMERA: "the point is not in front of the camera and its housing",
    RayStatus.NOT_CONVERGED: "the back-projection did not converge",
    RayStatus.OUTSIDE_FRAME: "the point projects outside the image frame",
    RayStatus.PARALLEL_RAYS: "the rays are (nearly) parallel: no intersection",
    RayStatus.FAILED_RAY: "one of the rays could not be traced",
    RayStatus.DIVERGING_RAYS: "the rays diverge: they come nearest each other behind the cameras (left and right "
                              "picks swapped, or not of one point?)",
    RayStatus.DISTORTION_FOLDS: "the calibration's lens distortion cannot be undone at this pixel (its polynomial "
                                "folds over there: the calibration does not hold so far from the centre)",
}


def describe_status(status: np.ndarray) -> str:
    """A one-line summary such as ``"3 of 100 failed: 2 totally reflected ..., 1 ..."``."""
    status = np.asarray(status)
    failed = status != RayStatus.OK
    if not np.any(failed):
        return f"all {status.size} valid"
    codes, counts = np.unique(status[failed], return_counts=True)
    parts = [f"{count} {RayStatus(int(code)).reason}" for code, count in zip(codes, counts, strict=True)]
    return f"{int(failed.sum())} of {status.size} failed: " + "; ".join(parts)


def require_all_ok(status: np.ndarray, what: str, where: np.ndarray | None = None) -> None:
    """Raise :class:`DegenerateGeometryError` naming the first row whose status is not OK (and, with
    ``where``, the surface at fault) with a summary of all failures."""
    bad = np.flatnonzero(np.asarray(status) != RayStatus.OK)
    if bad.size:
        first = int(bad[0])
        surface = int(where[first]) if where is not None else -1
        at = f" at surface {surface}" if surface >= 0 else ""
        raise DegenerateGeometryError(
            f"{what} {first}: {RayStatus(int(status[first])).reason}{at} ({describe_status(status)})")


@dataclass(frozen=True)
class RayBundle:
    """N rays: ``origins`` (N, 3) and unit ``directions`` (N, 3) in one frame (metres).

    After tracing through a housing the origin is the last refraction point (on the outer cover
    surface) and the direction is that of the ray in the outer medium (water). ``status`` (N,) holds
    :class:`RayStatus` codes; ``failed_surface`` (N,) the index of the surface where a ray failed (−1).
    """

    origins: np.ndarray
    directions: np.ndarray
    status: np.ndarray
    failed_surface: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        return self.status == RayStatus.OK

    def __len__(self) -> int:
        return self.origins.shape[0]

    def require_ok(self, what: str = "ray") -> RayBundle:
        """Return self, or raise :class:`DegenerateGeometryError` naming the first failed row."""
        bad = np.flatnonzero(~self.ok)
        if bad.size:
            first = int(bad[0])
            surface = int(self.failed_surface[first])
            where = f" at surface {surface}" if surface >= 0 else ""
            raise DegenerateGeometryError(
                f"{what} {first}: {RayStatus(int(self.status[first])).reason}{where} "
                f"({describe_status(self.status)})"
            )
        return self
