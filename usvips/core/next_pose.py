"""Where to hold the calibration target next: the largest gap the views so far leave — in the image, in
distance and in tilt — turned into one pose a person can take (pure: numpy/scipy, no files).

From the views' detections (:class:`StereoView`, corner pixels per camera) and the target's points, each
view's geometry is read as :func:`usvips.core.calibration_views.view_geometry` reads it (the grid cells its
points cover, its scale in pixels per metre — larger is nearer — and its tilt about a vertical or a
horizontal axis). Then:

* **Area**: per camera, every grid cell's distance (in cells) to the nearest cell a view covers; the cell
  farthest from any covered one is the centre of the largest empty region (ties: the camera with the
  larger gap, then the cell covered least by the other camera, then the one farther from the image's
  centre). With every cell covered, the least-covered cell.
* **Distance**: the views' scales (left camera). When they vary by less than :data:`DISTANCE_RATIO`, the
  board is to be held nearer when it fills less than :data:`NEAR_SHARE` of the image's height, else
  farther; otherwise the scale band (factor :data:`~usvips.core.calibration_views.DISTANCE_BAND`)
  between the smallest and the largest with the fewest views. The suggestion is the size the board
  should have across in the image (pixels), which a person can see, not metres.
* **Tilt**: views tilted at least :data:`TILT_MIN_DEG` counted per axis (turned about a vertical axis,
  tipped about a horizontal one); the axis with fewer, at :data:`TILT_AIM_DEG`.

The largest gap names what the suggestion is mainly for: an empty region of at least
:data:`AREA_GAP_CELLS` cells' reach comes first, then a missing tilt axis, then too little change of
distance, then the area covered least.

Conventions: pixels x right, y down, origin at the centre of the top-left pixel; angles in degrees where a
name says ``_deg``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from usvips.core.calibration_targets.detection import StereoView
from usvips.core.calibration_views import DEFAULT_GRID, DISTANCE_BAND, ViewGeometry, view_geometry
from usvips.core.errors import InvalidParameterError
from usvips.core.observations import ControlPoints

#: an empty region whose centre is at least this many cells from any covered cell is the largest gap
AREA_GAP_CELLS = 1.5
#: distances (largest over smallest scale) varying less than this are too alike
DISTANCE_RATIO = 1.3
#: a board filling less than this share of the image's height is to be brought nearer (else moved away)
NEAR_SHARE = 0.45
#: a tilt counts from this many degrees
TILT_MIN_DEG = 20.0
#: the tilt suggested (degrees)
TILT_AIM_DEG = 35.0

_THIRDS = (("upper left", "top", "upper right"), ("left", "centre", "right"), ("lower left", "bottom", "lower right"))


@dataclass(frozen=True)
class PoseSuggestion:
    """Where to hold the board next.

    ``camera`` whose image the area is named in; ``cell`` (column, row) of the grid and ``pixel`` its
    centre; ``region`` in words (upper left … lower right); ``size_px``: how large the board should look
    across (pixels, its larger extent) and ``sizes_px`` (smallest, largest) of the views so far;
    ``tilt_deg`` and ``tilt_axis`` (``vertical``: turn it left or right; ``horizontal``: tip it up or
    down); ``gap``: what is mainly missing (``area``, ``tilt``, ``distance`` or ``least covered``)."""

    camera: str
    cell: tuple[int, int]
    pixel: tuple[float, float]
    region: str
    size_px: float
    sizes_px: tuple[float, float]
    tilt_deg: float
    tilt_axis: str
    gap: str

    def text(self) -> str:
        """One sentence a person can act on."""
        turn = "turned left or right" if self.tilt_axis == "vertical" else "tipped up or down"
        low, high = self.sizes_px
        if self.size_px > 1.05 * high:
            distance = f"nearer, about {self.size_px:.0f} px across (so far {low:.0f}–{high:.0f} px)"
        elif self.size_px < 0.95 * low:
            distance = f"farther, about {self.size_px:.0f} px across (so far {low:.0f}–{high:.0f} px)"
        else:
            distance = f"about {self.size_px:.0f} px across"
        why = {"area": "the largest empty part of the images", "tilt": "no view is tilted that way yet",
               "distance": "the distances vary too little", "least covered": "the part covered least"}[self.gap]
        return (f"hold the board in the {self.region} of the {self.camera} image (near x {self.pixel[0]:.0f}, "
                f"y {self.pixel[1]:.0f} px), {distance}, {turn} by about {self.tilt_deg:.0f}° — {why}")


def _region(cell: tuple[int, int], grid: tuple[int, int]) -> str:
    column, row = cell
    cols, rows = grid
    return _THIRDS[min(int(3 * (row + 0.5) / rows), 2)][min(int(3 * (column + 0.5) / cols), 2)]


def _counts(geometries: Sequence[ViewGeometry], grid: tuple[int, int]) -> np.ndarray:
    cols, rows = grid
    counts = np.zeros(rows * cols, dtype=np.int64)
    for g in geometries:
        counts[list(g.cells)] += 1
    return counts.reshape(rows, cols)


def _area(counts: dict[str, np.ndarray]) -> tuple[str, tuple[int, int], float]:
    """(camera, (column, row), reach in cells) of the centre of the largest empty region."""
    best = None
    for camera, grid_counts in counts.items():
        other = counts["right" if camera == "left" else "left"]
        rows, cols = grid_counts.shape
        empty = grid_counts == 0
        reach = ndimage.distance_transform_edt(empty) if empty.any() and not empty.all() else \
            np.where(empty, float(max(rows, cols)), 0.0)
        r, c = np.indices(grid_counts.shape)
        off_centre = np.hypot((c + 0.5) / cols - 0.5, (r + 0.5) / rows - 0.5)
        # the key sorts: larger reach, then fewer views in the other camera, then farther off-centre
        key = np.stack([reach, -other, off_centre], axis=-1).reshape(-1, 3)
        order = np.lexsort((key[:, 2], key[:, 1], key[:, 0]))
        k = int(order[-1])
        candidate = (float(reach.flat[k]), camera, (k % cols, k // cols))
        if best is None or candidate[0] > best[0]:
            best = candidate
    reach, camera, cell = best
    return camera, cell, reach


def _least_covered(counts: dict[str, np.ndarray]) -> tuple[str, tuple[int, int]]:
    total = counts["left"] + counts["right"]
    rows, cols = total.shape
    k = int(np.argmin(total))
    camera = "left" if counts["left"].flat[k] <= counts["right"].flat[k] else "right"
    return camera, (k % cols, k // cols)


def suggest(views: Sequence[StereoView], target: ControlPoints, grid: tuple[int, int] = DEFAULT_GRID,
            focal_px: float | None = None) -> PoseSuggestion | None:
    """The next pose to fill the views' largest gap (see the module's notes); None without views.
    ``focal_px`` as in :func:`~usvips.core.calibration_views.view_geometry` (tilts only)."""
    views = list(views)
    if not views:
        return None
    cols, rows = (int(v) for v in grid)
    if cols < 1 or rows < 1:
        raise InvalidParameterError("grid", f"needs at least one column and one row, got {grid!r}")
    geometries = {side: [view_geometry(getattr(v, side), target, (cols, rows), focal_px) for v in views]
                  for side in ("left", "right")}
    counts = {side: _counts(g, (cols, rows)) for side, g in geometries.items()}
    camera, cell, reach = _area(counts)
    width, height = (float(s) for s in views[0].left.image_size)
    # the board's size across in the image (pixels) per view, from its points' extent
    sizes = np.array([float(np.ptp(v.left.pixels, axis=0).max()) for v in views])
    scales = np.array([g.scale for g in geometries["left"]], float)
    ok = np.isfinite(scales) & (scales > 0)
    ratio = float(scales[ok].max() / scales[ok].min()) if ok.any() else 1.0
    low, high = float(sizes.min()), float(sizes.max())
    distance_short = ratio < DISTANCE_RATIO
    if distance_short:
        size = min(1.6 * high, 0.9 * min(width, height)) if np.median(sizes) < NEAR_SHARE * height \
            else max(0.6 * low, 0.1 * min(width, height))
    else:  # the scale band between the nearest and the farthest view with the fewest views, as a size
        bands = np.floor(np.log(scales[ok] / scales[ok].min()) / np.log(DISTANCE_BAND)).astype(int)
        band = int(np.argmin(np.bincount(bands)))
        size_per_scale = float(np.median(sizes[ok] / scales[ok]))
        size = float(np.clip(size_per_scale * scales[ok].min() * DISTANCE_BAND ** (band + 0.5), low, high))
    tilted = {"vertical": 0, "horizontal": 0}
    for side in ("left", "right"):
        for g in geometries[side]:
            if np.isfinite(g.tilt) and np.degrees(g.tilt) >= TILT_MIN_DEG and g.tilt_axis in tilted:
                tilted[g.tilt_axis] += 1
    axis = min(tilted, key=lambda a: (tilted[a], a != "horizontal"))
    tilt_missing = tilted[axis] == 0
    if reach >= AREA_GAP_CELLS:
        gap = "area"
    elif tilt_missing:
        gap = "tilt"
    elif distance_short:
        gap = "distance"
    else:
        gap = "least covered"
        camera, cell = _least_covered(counts)
    pixel = ((cell[0] + 0.5) * width / cols, (cell[1] + 0.5) * height / rows)
    return PoseSuggestion(camera, cell, pixel, _region(cell, (cols, rows)), float(size), (low, high),
                          TILT_AIM_DEG, axis, gap)
