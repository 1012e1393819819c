"""Which views of a calibration target to calibrate from: blur, near-duplicates, a diverse subset, coverage.

A calibration needs the target seen all over each image, at several distances and tilted in several
directions; a video of a board moved in front of the rig gives thousands of instants, most of them alike
and some blurred. This module judges views from their detections (:class:`TargetDetection`, one per
camera, paired in a :class:`StereoView`) and chooses among them. Pure: numpy and OpenCV, no files.

Conventions: pixels x right, y down, origin at the centre of the top-left pixel; target coordinates in
metres (the target's own frame); angles in radians unless a name says ``_deg``.

* **Blur** (:func:`edge_width`): at each detected point, the width (pixels) over which the image crosses
  from dark to light: the local contrast (2nd to 98th percentile) divided by the steepest gradient. A
  sharp step edge sampled by pixels is about 2 px wide; a Gaussian blur of σ px widens it to about
  2.5 σ; motion blur of L px to about L. The width does not depend on the image's size, brightness or
  contrast, so one threshold (:data:`MAX_EDGE_WIDTH_PX`) serves every camera.
* **Geometry of a view** (:func:`view_geometry`): the grid cells of the image its points' hull covers,
  its scale (pixels per metre of target at its centre, the larger singular value of the local map from
  the target's plane to the image: larger is nearer) and its tilt (the angle between the target's plane
  and the image plane, from its pose through a pinhole of a given or guessed focal length: a planar
  target's homography decomposed, a 3-D field resected), and whether the board is turned about a
  vertical axis (its normal leans left-right) or a horizontal one.
* **Near-duplicates** (:func:`is_duplicate`): two views whose shared points lie within a few pixels of
  each other in both cameras.
* **Diverse subset** (:func:`select_views`): greedy, each step taking the view that adds most, counting
  every image cell of each camera, every distance band and every tilt band a view falls in with
  diminishing returns (1 / (1 + times already covered)).
* **Coverage** (:func:`coverage`): per camera the cells covered (a coarse map for the GUI), the spread of
  scales and tilts, and advice in words.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from usvips.core.calibration_targets.detection import StereoView, TargetDetection
from usvips.core.errors import InvalidParameterError
from usvips.core.observations import ControlPoints

#: an edge wider than this (pixels) counts as blurred (a sharp edge is ~2 px wide, see :func:`edge_width`)
#: when it is also wider than :data:`BLUR_SHARE` of the spacing of the target's points (:func:`blur_limit_px`)
MAX_EDGE_WIDTH_PX = 4.0
#: edges narrower than this share of the spacing between the target's points (pixels) do not count as
#: blurred, however wide: a corner's edges merge with its neighbours' only beyond half the spacing (real
#: cameras at a few hundred pixels show 3–8 px edges on boards that calibrate well; a board that moved
#: during the exposure shows edges as wide as the spacing)
BLUR_SHARE = 0.5
#: two views whose shared points all lie within this many pixels in both cameras are duplicates
DUPLICATE_PX = 3.0
#: the coverage grid, columns × rows, when none is given (cells of a 4:3 image are about square)
DEFAULT_GRID = (8, 6)
#: fewer views than this draws the advice to film more
RECOMMENDED_VIEWS = 15
#: tilt bands (degrees) of the selection and the advice
TILT_BANDS_DEG = (0.0, 10.0, 20.0, 30.0, 45.0, 90.0)
#: width of a distance band: the scale (px/m) changes by this factor from one band to the next
DISTANCE_BAND = 1.25
#: the selection's weights: one image cell of one camera counts 1, a distance band and a tilt band of one
#: camera count this much (a new distance or tilt is worth several cells of a view already near them)
BAND_WEIGHT = 6.0

_REGION_NAMES = (("upper left", "top", "upper right"), ("left", "centre", "right"),
                 ("lower left", "bottom", "lower right"))


# ---------------------------------------------------------------------------------------------- blur
def edge_width(image: np.ndarray, detection: TargetDetection, half: int | None = None) -> float:
    """The blur of ``image`` (grey or colour, any dtype) around the detected points: the width (pixels)
    of its blurriest edges.

    At each point, a (2·half + 1)² patch; each pixel's gradient (central differences) is divided by the
    contrast around it (98th − 2nd percentile of intensity over twice the patch) and filed by its
    direction (8 bands over 180°). In each band with edges in it, the width is one over the steepest
    normalised gradient (98th percentile): about 2 px for a sharp edge, 2.5 σ for Gaussian blur σ,
    L · |cos| for motion blur over L px at an angle to the edge's normal. The result is the widest
    band's, so motion blur in any direction shows. It depends on neither the brightness nor the
    contrast. ``half`` defaults to a third of the median spacing of the points, clipped to 3–12 px.
    NaN when no patch has contrast."""
    if not detection:
        return float("nan")
    grey = np.asarray(image)
    if grey.ndim == 3:
        grey = cv2.cvtColor(grey[..., :3], cv2.COLOR_BGR2GRAY) if grey.shape[2] >= 3 else grey[..., 0]
    grey = grey.astype(np.float32)
    h, w = grey.shape
    pixels = detection.pixels
    if half is None:
        half = int(np.clip(round(_median_spacing(pixels) / 3.0), 3, 12)) if len(pixels) > 1 else 6
    half = int(half)
    if half < 2:
        raise InvalidParameterError("half", f"the patch half-size must be at least 2 pixels, got {half}")
    cols = np.rint(pixels[:, 0]).astype(int)
    rows = np.rint(pixels[:, 1]).astype(int)
    reach = 2 * half  # the contrast is read over twice the patch: blur lowers it near a corner
    inside = (cols - reach >= 0) & (rows - reach >= 0) & (cols + reach < w) & (rows + reach < h)
    if not inside.any():
        return float("nan")
    offsets = np.arange(-half - 1, half + 2)
    wide = np.arange(-reach, reach + 1, 2)
    # patches (M, 2·half + 3, 2·half + 3) gathered at once; gradients by central differences inside them
    patches = grey[rows[inside, None, None] + offsets[None, :, None], cols[inside, None, None] + offsets[None, None, :]]
    surround = grey[rows[inside, None, None] + wide[None, :, None], cols[inside, None, None] + wide[None, None, :]]
    gx = (0.5 * (patches[:, 1:-1, 2:] - patches[:, 1:-1, :-2])).reshape(len(patches), -1)
    gy = (0.5 * (patches[:, 2:, 1:-1] - patches[:, :-2, 1:-1])).reshape(len(patches), -1)
    low, high = np.percentile(surround.reshape(len(patches), -1), [2.0, 98.0], axis=1)
    contrast = high - low
    usable = contrast > 1e-6 * max(float(np.abs(surround).max()), 1.0)
    if not usable.any():
        return float("nan")
    magnitude = (np.hypot(gx, gy)[usable] / contrast[usable, None]).ravel()
    band = (np.floor((np.arctan2(gy, gx)[usable].ravel() % np.pi) / (np.pi / 8)).astype(int)) % 8
    edge = magnitude > 0.04  # an edge pixel: a slope of at least 4 % of the contrast per pixel
    widths = []
    for b in range(8):
        values = magnitude[edge & (band == b)]
        if len(values) >= max(8, 0.05 * edge.sum()):
            widths.append(1.0 / float(np.percentile(values, 98.0)))
    return float(max(widths)) if widths else float("nan")


def blur_limit_px(detection: TargetDetection, floor_px: float = MAX_EDGE_WIDTH_PX,
                  share: float = BLUR_SHARE) -> float:
    """The widest edges (pixels, :func:`edge_width`) a detection's image may show before it counts as
    blurred: ``share`` × the median spacing of its points, but never less than ``floor_px``."""
    if len(detection.pixels) < 2:
        return float(floor_px)
    return max(float(floor_px), share * _median_spacing(detection.pixels))


def _median_spacing(pixels: np.ndarray) -> float:
    """Median distance (px) from each point to its nearest neighbour."""
    d = np.linalg.norm(pixels[:, None, :] - pixels[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    return float(np.median(d.min(axis=1)))


# ---------------------------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class ViewGeometry:
    """Where and how a target lies in one image.

    ``cells``: flat indices (row · columns + column) of the grid cells its points' hull covers;
    ``grid`` (columns, rows); ``scale``: pixels per metre of target along its least foreshortened
    direction (larger is nearer: distance ≈ focal length (px) / scale); ``tilt``: radians between the
    target plane and the image plane (NaN when it cannot be read: too few points); ``tilt_axis``:
    "vertical" (board turned about a vertical axis, compressed left-right) or "horizontal"."""

    cells: frozenset[int]
    grid: tuple[int, int]
    scale: float
    tilt: float
    tilt_axis: str


def _check_grid(grid: tuple[int, int]) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in grid)
    except (TypeError, ValueError):
        raise InvalidParameterError("grid", f"needs (columns, rows), got {grid!r}") from None
    if cols < 1 or rows < 1:
        raise InvalidParameterError("grid", f"needs at least one column and one row, got {cols} × {rows}")
    return cols, rows


def covered_cells(pixels: np.ndarray, image_size: tuple[int, int], grid: tuple[int, int] = DEFAULT_GRID,
                  share: float = 0.25) -> frozenset[int]:
    """Flat indices of the grid cells (``grid`` = columns, rows over the ``image_size`` = width, height)
    of which the convex hull of ``pixels`` covers at least ``share``."""
    cols, rows = _check_grid(grid)
    width, height = image_size
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    if len(pixels) == 0:
        return frozenset()
    sub = 8  # raster the hull at 8 × 8 samples per cell
    scale = np.array([cols * sub / width, rows * sub / height])
    raster = np.zeros((rows * sub, cols * sub), np.uint8)
    points = (pixels + 0.5) * scale  # pixel edges at -0.5 map to 0
    hull = cv2.convexHull(np.round(points * 16).astype(np.int32))
    cv2.fillConvexPoly(raster, hull, 1, cv2.LINE_8, 4)
    # a hull thinner than a raster sample (a line of points) still marks the cells it runs through
    inside = np.floor(points).astype(int)
    ok = (inside[:, 0] >= 0) & (inside[:, 1] >= 0) & (inside[:, 0] < cols * sub) & (inside[:, 1] < rows * sub)
    raster[inside[ok, 1], inside[ok, 0]] = 1
    fraction = raster.reshape(rows, sub, cols, sub).mean(axis=(1, 3))
    marked = fraction >= share
    marked[inside[ok, 1] // sub, inside[ok, 0] // sub] = True
    return frozenset(int(i) for i in np.flatnonzero(marked))


def _plane_frame(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """The target's centroid (m), its axes (rows: the two largest extents, then the normal) and whether it
    is planar (smallest extent under a millionth of the largest). ``xyz`` holds at least 3 points."""
    centre = xyz.mean(axis=0)
    _, singular, axes = np.linalg.svd(xyz - centre, full_matrices=True)
    planar = bool(singular[0] == 0 or len(singular) < 3 or singular[2] / singular[0] < 1e-6)
    return centre, axes, planar


def _camera_matrix(image_size: tuple[int, int], focal_px: float | None) -> np.ndarray:
    width, height = image_size
    focal = float(max(width, height)) if focal_px is None else float(focal_px)
    if not (np.isfinite(focal) and focal > 0):
        raise InvalidParameterError("focal_px", f"must be a positive number of pixels, got {focal_px}")
    return np.array([[focal, 0.0, (width - 1) / 2], [0.0, focal, (height - 1) / 2], [0.0, 0.0, 1.0]])


def _scale_and_normal(xyz: np.ndarray, pixels: np.ndarray, k: np.ndarray) -> tuple[float, np.ndarray | None]:
    """Pixels per metre at the target's centre (largest singular value of the plane-to-image map) and the
    target's normal (smallest extent) in the camera frame (x right, y down, z forward), or None."""
    centre, axes, planar = _plane_frame(xyz)
    local = (xyz - centre) @ axes.T
    if planar:
        homography, _ = cv2.findHomography(local[:, :2], pixels, 0)
        if homography is None or not np.all(np.isfinite(homography)) or abs(homography[2, 2]) < 1e-12:
            return float("nan"), None
        h = homography / homography[2, 2]
        # d(pixel)/d(plane) at the plane's origin (the centroid): A − t·h3ᵀ
        jacobian = h[:2, :2] - np.outer(h[:2, 2], h[2, :2])
        columns = np.linalg.solve(k, h)  # ∝ [r1 r2 t] of the plane in the camera
        normal = np.cross(columns[:, 0], columns[:, 1])
    else:
        design = np.column_stack([local, np.ones(len(local))])
        solution, *_ = np.linalg.lstsq(design, pixels, rcond=None)
        jacobian = solution[:2, :].T
        ok, rvec, _ = cv2.solvePnP(xyz.reshape(-1, 1, 3), pixels.reshape(-1, 1, 2), k, None,
                                   flags=cv2.SOLVEPNP_EPNP)
        normal = cv2.Rodrigues(rvec)[0] @ axes[2] if ok else None
    singular = np.linalg.svd(jacobian, compute_uv=False)
    scale = float(singular[0]) if np.all(np.isfinite(singular)) and singular[0] > 0 else float("nan")
    if normal is None or not np.all(np.isfinite(normal)) or np.linalg.norm(normal) == 0:
        return scale, None
    return scale, normal / np.linalg.norm(normal)


def view_geometry(detection: TargetDetection, target: ControlPoints | None = None,
                  grid: tuple[int, int] = DEFAULT_GRID, focal_px: float | None = None) -> ViewGeometry:
    """The cells, scale and tilt of one detection (see :class:`ViewGeometry`).

    With ``target`` (the target's control points, matched by id): the scale from the target's
    plane-to-image map, and the tilt from the target's pose (a planar target's homography decomposed,
    a 3-D field's resection) through a pinhole of focal length ``focal_px`` (pixels; by default the
    image's larger side, a 53° lens: a focal length 30 % off moves a tilt by up to about 10°) with the
    principal point at the image centre. Without it, the scale is the square root of the hull's area
    over the image's area, and the tilt is NaN."""
    grid = _check_grid(grid)
    cells = covered_cells(detection.pixels, detection.image_size, grid)
    tilt, axis, scale = float("nan"), "", float("nan")
    if target is not None and len(detection) >= 6:
        k = _camera_matrix(detection.image_size, focal_px)
        scale, normal = _scale_and_normal(target.subset(detection.ids).xyz, detection.pixels, k)
        if normal is not None:
            tilt = float(np.arccos(min(abs(float(normal[2])), 1.0)))
            axis = "vertical" if abs(normal[0]) >= abs(normal[1]) else "horizontal"
    if not np.isfinite(scale) and len(detection) >= 3:
        hull = cv2.convexHull(detection.pixels.astype(np.float32))
        width, height = detection.image_size
        scale = float(np.sqrt(cv2.contourArea(hull) / (width * height)))
    return ViewGeometry(cells, grid, scale, tilt, axis)


# ---------------------------------------------------------------------------------------------- duplicates
def _shared_distances(a: TargetDetection, b: TargetDetection) -> np.ndarray:
    index = {pid: i for i, pid in enumerate(b.ids)}
    pairs = [(i, index[pid]) for i, pid in enumerate(a.ids) if pid in index]
    if not pairs:
        return np.empty(0)
    ia, ib = np.array(pairs).T
    return np.linalg.norm(a.pixels[ia] - b.pixels[ib], axis=1)


def is_duplicate(a: StereoView, b: StereoView, tolerance_px: float = DUPLICATE_PX) -> bool:
    """Whether ``b`` shows the target where ``a`` does: in both cameras, at least half of the smaller
    detection's points are shared and every shared point lies within ``tolerance_px`` pixels."""
    if not tolerance_px > 0:
        raise InvalidParameterError("tolerance_px", f"must be positive, got {tolerance_px}")
    for first, second in ((a.left, b.left), (a.right, b.right)):
        distances = _shared_distances(first, second)
        if len(distances) == 0 or len(distances) < 0.5 * min(len(first), len(second)):
            return False
        if distances.max() > tolerance_px:
            return False
    return True


def drop_duplicates(views: Sequence[StereoView], tolerance_px: float = DUPLICATE_PX
                    ) -> tuple[list[StereoView], list[tuple[StereoView, StereoView]]]:
    """The views without near-duplicates (the first of each group kept, in order), and each dropped view
    with the kept view it repeats."""
    kept: list[StereoView] = []
    dropped: list[tuple[StereoView, StereoView]] = []
    for view in views:
        twin = next((k for k in reversed(kept) if is_duplicate(k, view, tolerance_px)), None)
        if twin is None:
            kept.append(view)
        else:
            dropped.append((view, twin))
    return kept, dropped


# ---------------------------------------------------------------------------------------------- selection
def _tilt_band(tilt: float) -> int:
    if not np.isfinite(tilt):
        return -1
    return int(np.clip(np.searchsorted(TILT_BANDS_DEG, np.degrees(tilt), side="right") - 1, 0,
                       len(TILT_BANDS_DEG) - 2))


def _features(geometries: Sequence[tuple[ViewGeometry, ViewGeometry]]) -> tuple[np.ndarray, np.ndarray]:
    """The incidence matrix (views × features) of what each view covers and each feature's weight."""
    keys: dict[tuple, int] = {}
    rows: list[list[int]] = []
    scales = np.array([[g.scale for g in pair] for pair in geometries], dtype=np.float64)
    floor = np.nanmin(scales, axis=0) if np.isfinite(scales).any() else np.ones(2)
    for pair in geometries:
        row = []
        for camera, geometry in enumerate(pair):
            names = [("cell", camera, c) for c in geometry.cells]
            if np.isfinite(geometry.scale) and geometry.scale > 0 and np.isfinite(floor[camera]):
                names.append(("distance", camera, int(np.log(geometry.scale / floor[camera]) // np.log(DISTANCE_BAND))))
            band = _tilt_band(geometry.tilt)
            if band >= 0:
                names.append(("tilt", camera, band, geometry.tilt_axis if band > 0 else ""))
            row += [keys.setdefault(name, len(keys)) for name in names]
        rows.append(row)
    incidence = np.zeros((len(geometries), len(keys)))
    for i, row in enumerate(rows):
        incidence[i, row] = 1.0
    weights = np.array([1.0 if name[0] == "cell" else BAND_WEIGHT for name in keys])
    return incidence, weights


def select_views(views: Sequence[StereoView], max_views: int, target: ControlPoints | None = None,
                 grid: tuple[int, int] = DEFAULT_GRID, blur: Sequence[float] | None = None,
                 focal_px: float | None = None) -> list[StereoView]:
    """Up to ``max_views`` of ``views``, chosen greedily for diversity (see the module's notes), in their
    original order. ``blur`` (an edge width per view, px) breaks ties in favour of the sharper view;
    ``target`` and ``focal_px`` as in :func:`view_geometry`."""
    max_views = int(max_views)
    if max_views < 1:
        raise InvalidParameterError("max_views", f"must be at least 1, got {max_views}")
    if len(views) <= max_views:
        return list(views)
    geometries = [(view_geometry(v.left, target, grid, focal_px), view_geometry(v.right, target, grid, focal_px))
                  for v in views]
    incidence, weights = _features(geometries)
    tie = np.zeros(len(views))
    if blur is not None:
        widths = np.asarray(blur, dtype=np.float64)
        if widths.shape != (len(views),):
            raise InvalidParameterError("blur", f"one edge width per view needed ({len(views)}), got {widths.shape}")
        tie = -1e-6 * np.nan_to_num(widths, nan=1e3)
    counts = np.zeros(incidence.shape[1])
    chosen = np.zeros(len(views), bool)
    for _ in range(max_views):
        gain = incidence @ (weights / (1.0 + counts)) + tie
        gain[chosen] = -np.inf
        best = int(np.argmax(gain))
        chosen[best] = True
        counts += incidence[best]
    return [v for v, keep in zip(views, chosen, strict=True) if keep]


# ---------------------------------------------------------------------------------------------- coverage
def _listed(words: list[str]) -> str:
    """"a", "a and b", "a, b and c"."""
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


@dataclass(frozen=True)
class CameraCoverage:
    """One camera's coverage by a set of views.

    ``camera``: "left" or "right"; ``counts`` (rows, columns): how many views cover each grid cell (the
    map the GUI draws over the image); ``scales`` (px/m, or relative without a target) and ``tilts``
    (radians, NaN where unknown) and ``tilt_axes`` of each view."""

    camera: str
    counts: np.ndarray
    scales: np.ndarray
    tilts: np.ndarray
    tilt_axes: tuple[str, ...]

    @property
    def covered(self) -> float:
        """Share of the image's grid cells covered by at least one view (0 to 1)."""
        return float(np.mean(self.counts > 0))

    @property
    def distance_ratio(self) -> float:
        """Largest over smallest scale: how much the distance varies (1: all views at one distance)."""
        s = self.scales[np.isfinite(self.scales) & (self.scales > 0)]
        return float(s.max() / s.min()) if len(s) else float("nan")

    @property
    def largest_tilt_deg(self) -> float:
        t = self.tilts[np.isfinite(self.tilts)]
        return float(np.degrees(t.max())) if len(t) else float("nan")

    def region_shares(self) -> np.ndarray:
        """(3, 3) share of the grid cells covered in each third of the image (rows top to bottom)."""
        rows, cols = self.counts.shape
        centre_y = (np.arange(rows) + 0.5) / rows
        centre_x = (np.arange(cols) + 0.5) / cols
        region_row = np.minimum((centre_y * 3).astype(int), 2)
        region_col = np.minimum((centre_x * 3).astype(int), 2)
        shares = np.zeros((3, 3))
        for r in range(3):
            for c in range(3):
                block = self.counts[np.ix_(region_row == r, region_col == c)]
                shares[r, c] = float(np.mean(block > 0)) if block.size else 1.0
        return shares


@dataclass(frozen=True)
class Coverage:
    """The coverage of a set of views: per camera (:class:`CameraCoverage`), the number of views and
    advice in words (empty when nothing is missing)."""

    left: CameraCoverage
    right: CameraCoverage
    views: int
    advice: tuple[str, ...]

    def summary(self) -> list[str]:
        """Lines for a person: per camera the area covered, distances and tilts; then the advice."""
        lines = [f"{self.views} views"]
        for cam in (self.left, self.right):
            ratio = cam.distance_ratio
            tilt = cam.largest_tilt_deg
            lines.append(f"{cam.camera}: {100 * cam.covered:.0f} % of the image covered"
                         + (f", distances vary {ratio:.2f} : 1" if np.isfinite(ratio) else "")
                         + (f", tilts up to {tilt:.0f}°" if np.isfinite(tilt) else ""))
        return lines + list(self.advice)


def coverage(views: Sequence[StereoView], target: ControlPoints | None = None,
             grid: tuple[int, int] = DEFAULT_GRID, recommended_views: int = RECOMMENDED_VIEWS,
             minimum_tilt_deg: float = 20.0, minimum_distance_ratio: float = 1.3,
             focal_px: float | None = None) -> Coverage:
    """What ``views`` cover in each camera and what is missing, in words: too few views (fewer than
    ``recommended_views``), a third of an image with little or nothing in it, tilts all under
    ``minimum_tilt_deg`` or only about one axis, distances that vary by less than
    ``minimum_distance_ratio`` (largest over smallest scale). ``focal_px``: see :func:`view_geometry`."""
    cols, rows = _check_grid(grid)
    cameras = []
    for camera in ("left", "right"):
        geometries = [view_geometry(getattr(v, camera), target, grid, focal_px) for v in views]
        counts = np.zeros(rows * cols, dtype=np.int64)
        for g in geometries:
            counts[list(g.cells)] += 1
        cameras.append(CameraCoverage(camera, counts.reshape(rows, cols),
                                      np.array([g.scale for g in geometries], dtype=np.float64),
                                      np.array([g.tilt for g in geometries], dtype=np.float64),
                                      tuple(g.tilt_axis for g in geometries)))
    left, right = cameras
    advice: list[str] = []
    if len(views) < recommended_views:
        advice.append(f"only {len(views)} view{'s' if len(views) != 1 else ''}: film at least {recommended_views}")
    if views:
        for cam in cameras:
            shares = cam.region_shares().ravel()
            names = [name for row in _REGION_NAMES for name in row]
            for word, empty in (("nothing", shares == 0), ("little", (shares > 0) & (shares < 0.5))):
                if empty.any():
                    advice.append(f"{word} in the {_listed([n for n, e in zip(names, empty, strict=True) if e])} "
                                  f"of the {cam.camera} image")
        tilts = np.concatenate([left.tilts, right.tilts])
        if np.isfinite(tilts).any():
            largest = float(np.degrees(np.nanmax(tilts)))
            if largest < minimum_tilt_deg:
                advice.append(f"tilt the board more: the largest tilt is {largest:.0f}° (aim for 30–50° in "
                              f"several directions)")
            else:
                axes = {a for cam in cameras for a, t in zip(cam.tilt_axes, cam.tilts, strict=True)
                        if np.isfinite(t) and np.degrees(t) >= minimum_tilt_deg}
                if axes == {"vertical"}:
                    advice.append("tilt the board up and down too: every tilt so far turns it left or right")
                elif axes == {"horizontal"}:
                    advice.append("turn the board left and right too: every tilt so far tips it up or down")
        ratio = left.distance_ratio
        if np.isfinite(ratio) and len(views) > 1 and ratio < minimum_distance_ratio:
            advice.append(f"vary the distance: the target's size in the left image varies only "
                          f"{100 * (ratio - 1):.0f} % (film it nearer and farther)")
    return Coverage(left, right, len(views), tuple(advice))
