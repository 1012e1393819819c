"""What the printed boards share: validation of their descriptions, the printed pattern (``ink``) for
rendering and printing, the image preparation for OpenCV's detectors, and a quality per found point.

Board frame (OpenCV's): the printed sheet seen from the front, x to the right, y down the sheet, z into
it (right-handed); metres; every point of a board lies in z = 0.
"""

from __future__ import annotations

from abc import abstractmethod

import cv2
import numpy as np

from usvips.core.calibration_targets.base import CalibrationTarget
from usvips.core.calibration_targets.detection import TargetDetection
from usvips.core.errors import InputFileError, InvalidParameterError, concerning
from usvips.core.observations import ControlPoints

#: OpenCV's predefined ArUco/AprilTag dictionaries by the names the description files use.
DICTIONARIES: dict[str, int] = {name[5:].upper(): getattr(cv2.aruco, name) for name in dir(cv2.aruco)
                                 if name.startswith("DICT_")}


def fail(source: str, field: str, problem: str) -> None:
    """Raise the one-line error of a bad description field (naming the file when there is one); either
    error concerns ``field`` (:attr:`usvips.core.errors.UsvipsError.parameter`)."""
    if source:
        raise concerning(InputFileError(source, f"field {field!r}: {problem}"), field)
    raise InvalidParameterError(field, problem)


def field(description: dict, name: str, source: str, default: object = None) -> object:
    """A description field; a missing one without default is named."""
    if name not in description:
        if default is None:
            fail(source, name, "missing")
        return default
    return description[name]


def count(description: dict, name: str, source: str, minimum: int = 2, default: int | None = None) -> int:
    """A whole number of points/squares/markers, at least ``minimum``."""
    value = field(description, name, source, default)
    if (isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value)
            or value != int(value)):
        fail(source, name, f"must be a whole number, got {value!r}")
    if value < minimum:
        fail(source, name, f"must be at least {minimum}, got {int(value)}")
    if value > 1000:
        fail(source, name, f"{int(value)} is not a plausible board size (at most 1000)")
    return int(value)


def length(description: dict, name: str, source: str, default: float | None = None) -> float:
    """A positive finite length in metres (a board larger than 10 m is refused as a unit mistake)."""
    value = field(description, name, source, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        fail(source, name, f"must be a length in metres, got {value!r}")
    if value <= 0:
        fail(source, name, f"must be > 0 (metres), got {value!r}")
    if value > 10:
        fail(source, name, f"{value!r} m is not a plausible size (metres are expected, not millimetres)")
    return float(value)


def flag(description: dict, name: str, source: str) -> bool:
    value = field(description, name, source, False)
    if not isinstance(value, bool):
        fail(source, name, f"must be true or false, got {value!r}")
    return value


def dictionary(description: dict, name: str, source: str) -> tuple[str, cv2.aruco.Dictionary]:
    """An OpenCV predefined dictionary by name (``4X4_50``, ``APRILTAG_36h11`` ...; ``DICT_`` optional)."""
    value = field(description, name, source)
    key = str(value).upper().removeprefix("DICT_") if isinstance(value, str) else None
    if key not in DICTIONARIES:
        fail(source, name, f"unknown dictionary {value!r}; known: {', '.join(sorted(DICTIONARIES))}")
    return key, cv2.aruco.getPredefinedDictionary(DICTIONARIES[key])


def unknown_fields(description: dict, known: set[str], source: str) -> None:
    """A field the kind does not know is a typo to name, not something to ignore."""
    extra = sorted(set(description) - known - {"kind", "version"})
    if extra:
        fail(source, extra[0], f"not a field of a {description.get('kind')} target (known: "
             f"{', '.join(sorted(known))})")


def marker_bits(dictionary: cv2.aruco.Dictionary, ids: np.ndarray) -> np.ndarray:
    """The printed modules of markers ``ids``: (N, m + 2, m + 2), 1 = white, with the black border."""
    m = int(dictionary.markerSize)
    out = np.zeros((len(ids), m + 2, m + 2), np.uint8)
    for k, marker in enumerate(ids):
        out[k] = cv2.aruco.generateImageMarker(dictionary, int(marker), m + 2, borderBits=1) > 127
    return out


def guarded(detect):
    """Wrap a kind's ``detect`` so that OpenCV failing on an odd image (too small for the detector's
    settings, say) is a falsy detection with the reason, never an exception."""
    import functools

    @functools.wraps(detect)
    def wrapper(self, image: np.ndarray) -> TargetDetection:
        grey = to_grey8(image)
        try:
            return detect(self, grey)
        except cv2.error as error:
            # OpenCV's bindings keep ``err`` (the short reason) on the exception class: trust it only when it
            # belongs to this error's own message (another error's may linger there)
            text, short = str(error), getattr(error, "err", None)
            problem = " ".join((short if isinstance(short, str) and short and short in text else text).split())[:200]
            return TargetDetection.nothing((grey.shape[1], grey.shape[0]), f"OpenCV could not search the image: "
                                           f"{problem}")
    return wrapper


#: Frames at least this long (pixels) are also searched halved (a downscaled search finds boards whose
#: features are large or slightly blurred at full size).
DOWNSCALE_SIDE_PX = 1280


def widen_marker_search(parameters: cv2.aruco.DetectorParameters) -> None:
    """Set ArUco detector ``parameters`` for a harder search: thresholds over windows of 3 to 73 pixels in
    steps of 7 (uneven light, large markers), markers as small as 1 % of the image's longer side
    (OpenCV's default: 3 %), and a looser polygon fit (perspective, lens distortion)."""
    parameters.adaptiveThreshWinSizeMin = 3
    parameters.adaptiveThreshWinSizeMax = 73
    parameters.adaptiveThreshWinSizeStep = 7
    parameters.minMarkerPerimeterRate = 0.01
    parameters.polygonalApproxAccuracyRate = 0.05


def to_grey8(image: np.ndarray) -> np.ndarray:
    """A grey uint8 image for OpenCV's detectors from grey or RGB, uint8 or uint16 (16-bit images are
    stretched so that their 99.9th percentile is white: 10- and 12-bit data fill the range)."""
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] in (3, 4):
        image = cv2.cvtColor(np.ascontiguousarray(image[:, :, :3]), cv2.COLOR_RGB2GRAY)
    if image.ndim != 2 or image.shape[0] < 8 or image.shape[1] < 8:
        raise InvalidParameterError("image", f"expected a grey (H, W) or colour (H, W, 3) image of at least "
                                    f"8 × 8 pixels, got shape {image.shape}")
    if image.dtype == np.uint8:
        return np.ascontiguousarray(image)
    if image.dtype == np.uint16:
        top = float(np.percentile(image[::4, ::4], 99.9)) or 1.0
        return np.clip(image.astype(np.float32) * (255.0 / top), 0, 255).astype(np.uint8)
    raise InvalidParameterError("image", f"expected uint8 or uint16 pixels, got {image.dtype}")


def _patches(grey: np.ndarray, pixels: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Windows of ``half`` pixels around each point (bilinear, float) and their central-difference
    gradients; the windows are cut one by one (``getRectSubPix``), never converting the whole image."""
    h = int(np.clip(round(half), 2, 20))
    k = 2 * h + 3
    patches = np.stack([cv2.getRectSubPix(grey, (k, k), (float(x), float(y)), patchType=cv2.CV_32F)
                        for x, y in pixels])
    gx = (patches[:, 1:-1, 2:] - patches[:, 1:-1, :-2]) / 2
    gy = (patches[:, 2:, 1:-1] - patches[:, :-2, 1:-1]) / 2
    return patches[:, 1:-1, 1:-1], gx, gy


def point_quality(grey: np.ndarray, pixels: np.ndarray, half: float) -> np.ndarray:
    """A found point's sharpness and contrast: the root-mean-square image gradient in its weakest
    direction (the square root of the smallest eigenvalue of the structure tensor) over a window of
    ``half`` pixels around it, in grey levels (0–255) per pixel. A sharp, contrasted corner scores tens;
    a blurred or faint one a few."""
    pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
    if not len(pixels):
        return np.empty(0)
    return _quality(*_patches(grey, pixels, half)[1:])


def _quality(gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    n = gx[0].size
    a, b, c = (gx * gx).sum((1, 2)) / n, (gx * gy).sum((1, 2)) / n, (gy * gy).sum((1, 2)) / n
    smallest = (a + c) / 2 - np.sqrt(((a - c) / 2) ** 2 + b * b)
    return np.sqrt(np.maximum(smallest, 0.0)).astype(np.float64)


def edge_width(grey: np.ndarray, pixels: np.ndarray, half: float) -> np.ndarray:
    """How wide (pixels) the blurriest edges near each point are: the window's contrast (2nd to 98th
    percentile) over the steepest gradient of each of its two main edge directions, the larger of the two
    — about 2.5 σ for a Gaussian blur of σ, about the blur length across edges smeared by motion (edges
    along the motion stay sharp; the total gradient of an edge does not change with blur, so the edge
    directions are found by it)."""
    pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
    if not len(pixels):
        return np.empty(0)
    return _edge_width(*_patches(grey, pixels, half))


def _edge_width(patches: np.ndarray, gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    n = len(patches)
    flat = np.sort(patches.reshape(n, -1), axis=1)
    m = flat.shape[1]
    contrast = flat[:, int(0.98 * (m - 1))] - flat[:, int(0.02 * (m - 1))]
    magnitude = np.sqrt(gx * gx + gy * gy).reshape(n, -1)
    bins = 8
    orientation = (np.floor((np.arctan2(gy, gx) % np.pi) / np.pi * bins).astype(np.int64) % bins).reshape(n, -1)
    total, steepest = np.empty((n, bins)), np.empty((n, bins))
    for b in range(bins):
        in_bin = np.where(orientation == b, magnitude, 0.0)
        total[:, b], steepest[:, b] = in_bin.sum(axis=1), in_bin.max(axis=1)
    main = np.argsort(total, axis=1)[:, -2:]
    weakest = np.take_along_axis(steepest, main, axis=1).min(axis=1)
    return contrast / np.maximum(weakest, 1e-9)


#: Edges wider than this (pixels) mean the target moved or was out of focus: the view is refused.
MAX_EDGE_WIDTH_PX = 6.0


def finished(grey: np.ndarray, ids: tuple[str, ...], pixels: np.ndarray, notes: tuple[str, ...] = (),
             max_edge_width: float = MAX_EDGE_WIDTH_PX, stage: str = "") -> TargetDetection:
    """The detection of points ``ids`` at ``pixels`` with their quality (:func:`point_quality`), found by
    the detector ``stage`` (its name), or a refusal naming the blur when the target's edges are wider
    than ``max_edge_width`` pixels."""
    size = (grey.shape[1], grey.shape[0])
    pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
    half = float(np.clip(0.3 * spacing_px(pixels), 2, 12))
    patches, gx, gy = _patches(grey, pixels, half)
    sample = np.unique(np.linspace(0, len(pixels) - 1, min(len(pixels), 24)).astype(np.intp))
    width = float(np.median(_edge_width(patches[sample], gx[sample], gy[sample])))
    if width > max_edge_width:
        return TargetDetection.nothing(size, f"the target is too blurred: its edges are {width:.1f} px wide "
                                       f"(at most {max_edge_width:g}); hold it still, focus, or expose shorter")
    return TargetDetection(tuple(ids), pixels, _quality(gx, gy), size, "", tuple(notes), stage)


def nearest_px(pixels: np.ndarray) -> np.ndarray:
    """Each found point's distance (pixels) to its nearest neighbour (10 px for a point alone)."""
    pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
    if len(pixels) < 2:
        return np.full(len(pixels), 10.0)
    d = np.linalg.norm(pixels[:, None, :] - pixels[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    return d.min(axis=1)


def spacing_px(pixels: np.ndarray) -> float:
    """The median distance (pixels) from each found point to its nearest neighbour."""
    pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
    return float(np.median(nearest_px(pixels))) if len(pixels) >= 2 else 10.0


#: The largest half-width (pixels) of a chessboard corner's refinement window (OpenCV's usual 11 × 11).
REFINE_HALF_MAX_PX = 11


def refine_corners(grey: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """OpenCV's ``cornerSubPix`` on chessboard corners, over a window of 0.35 × the corner spacing each
    side (on boards rendered through every housing: about 0.04 px RMS, where findChessboardCornersSB's own
    accuracy refinement gives about 0.12 px and costs five times its search). The spacing is each corner's
    own (the distance to its nearest neighbour, at most the board's median): on a board seen obliquely the
    squares on its far side are narrower than the median, and a window sized by the median reaches past a
    border corner's outer square to the board's edge, which pulls the corner by pixels (seen on real
    views). The window is at most :data:`REFINE_HALF_MAX_PX` each side: ``cornerSubPix`` takes the edges
    through a corner as straight, and a wider window sees them bent by the lens (on a wide-angle real set,
    MRPT's, capping the window there lowered the reprojection RMS from 0.17 to 0.16 px, as OpenCV's usual
    11 × 11 window gives; on three other real sets it moved by under 0.001 px). A corner nearer the image's
    edge than that is refined over a window that stays inside the image (a window cut by the edge pulls the
    corner by tenths of a pixel)."""
    pixels = np.ascontiguousarray(pixels, np.float32).reshape(-1, 2)
    halves = np.clip(np.round(0.35 * np.minimum(nearest_px(pixels), spacing_px(pixels))), 2,
                     REFINE_HALF_MAX_PX).astype(np.int64)
    height, width = grey.shape[:2]
    room = np.floor(np.minimum.reduce([pixels[:, 0], pixels[:, 1], width - 1 - pixels[:, 0],
                                       height - 1 - pixels[:, 1]])).astype(np.int64) - 1
    windows = np.clip(np.minimum(room, halves), 2, None)
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)
    refined = pixels.copy()
    for window in np.unique(windows):
        rows = windows == window
        refined[rows] = cv2.cornerSubPix(grey, np.ascontiguousarray(pixels[rows]).reshape(-1, 1, 2),
                                         (int(window), int(window)), (-1, -1), criteria).reshape(-1, 2)
    return refined.astype(np.float64)


UPRIGHT_NOTE = "symmetric board: point 0 taken as the one from which the board runs rightwards (upright rule)"
TURNED_TOO_FAR = ("the symmetric board is turned too near a quarter turn (or half way between two, if square) "
                  "for the upright rule to tell its point order: hold it more upright")
#: How much more nearly rightwards (difference of the x step's unit x component) the chosen ordering must
#: run than the next: the upright rule refuses a board turned within about 15° of a quarter turn (a
#: square board: within about 30° of half way between two), where two cameras could choose differently.
UPRIGHT_MARGIN = 0.5


def most_upright(candidates: list[np.ndarray]) -> np.ndarray | None:
    """Of the orderings (rows, cols, 2) of a symmetric board, the one whose x step runs most nearly
    rightwards in the image; None when another runs nearly as rightwards (see :data:`UPRIGHT_MARGIN`)."""
    def rightwards(candidate: np.ndarray) -> float:
        dx = (candidate[:, 1:] - candidate[:, :-1]).reshape(-1, 2).mean(axis=0)
        return float(dx[0] / np.linalg.norm(dx))

    scores = sorted(((rightwards(c), k) for k, c in enumerate(candidates)), reverse=True)
    if len(scores) > 1 and scores[0][0] - scores[1][0] < UPRIGHT_MARGIN:
        return None
    return candidates[scores[0][1]]


class PrintedBoard(CalibrationTarget):
    """A planar board printed on a sheet: its pattern (:meth:`ink`), the sheet it is printed on
    (:meth:`sheet`, with a white quiet zone around the pattern) and its black shapes for printing
    (:meth:`shapes`). Kinds of boards subclass this (it registers nothing itself)."""

    def __reduce__(self):
        """Pickled as its description (OpenCV's board and detector objects do not pickle), so a target can
        go to a worker process."""
        from usvips.core.calibration_targets.registry import from_description

        return from_description, (self.describe(),)

    @abstractmethod
    def ink(self, xy: np.ndarray) -> np.ndarray:
        """The printed pattern at board points ``xy`` (N, 2), metres: 1 where black, 0 where white, NaN off
        the sheet (exact: supersample to anti-alias)."""

    @abstractmethod
    def sheet(self) -> tuple[float, float, float, float]:
        """The printed sheet's extent (x0, y0, x1, y1), metres, board frame (pattern and quiet zone)."""

    @abstractmethod
    def shapes(self) -> tuple[np.ndarray, np.ndarray]:
        """The black shapes to print: axis-aligned rectangles (N, 4) ``x0, y0, x1, y1`` and circles (M, 3)
        ``x, y, radius``, metres, board frame."""

    @abstractmethod
    def feature_size(self) -> float:
        """The size (metres) of the board's smallest printed feature that a detector must resolve."""

    def control_points(self) -> ControlPoints:
        ids, xy = self.points()
        return ControlPoints(ids, np.column_stack([xy, np.zeros(len(xy))]), source=f"{self.kind} target")

    @abstractmethod
    def points(self) -> tuple[tuple[str, ...], np.ndarray]:
        """Point ids and their board coordinates (N, 2), metres."""

    @property
    def is_planar(self) -> bool:
        return True

    def _on_sheet(self, xy: np.ndarray) -> np.ndarray:
        x0, y0, x1, y1 = self.sheet()
        return (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)


def lattice_marker_ink(xy: np.ndarray, origin: tuple[float, float], pitch: float, size: float,
                       cells: np.ndarray, bits: np.ndarray) -> np.ndarray:
    """Ink (1 black, 0 white, NaN outside every marker) of markers laid on a square lattice: the marker of
    lattice cell (row, col) has its top-left corner at ``origin + (col, row) · pitch``, side ``size``;
    ``cells[row, col]`` indexes ``bits`` (−1: no marker in that cell)."""
    rel = (xy - np.asarray(origin)) / pitch
    col, row = np.floor(rel[:, 0]).astype(np.int64), np.floor(rel[:, 1]).astype(np.int64)
    inside = (col >= 0) & (row >= 0) & (col < cells.shape[1]) & (row < cells.shape[0])
    out = np.full(len(xy), np.nan)
    index = np.full(len(xy), -1)
    index[inside] = cells[row[inside], col[inside]]
    local = (rel - np.column_stack([col, row])) * pitch / size
    inside &= (index >= 0) & (local[:, 0] < 1) & (local[:, 1] < 1)
    modules = bits.shape[1]
    mx = np.minimum((local[inside, 0] * modules).astype(np.int64), modules - 1)
    my = np.minimum((local[inside, 1] * modules).astype(np.int64), modules - 1)
    out[inside] = 1.0 - bits[index[inside], my, mx]
    return out


def marker_rectangles(corners: np.ndarray, size: float, bits: np.ndarray) -> np.ndarray:
    """Black rectangles (x0, y0, x1, y1) of markers with top-left corners ``corners`` (N, 2): each row's
    runs of black modules as one rectangle."""
    modules = bits.shape[1]
    step = size / modules
    out = []
    for (x, y), marker in zip(corners, bits, strict=True):
        for r in range(modules):
            c = 0
            while c < modules:
                if marker[r, c] == 0:
                    start = c
                    while c < modules and marker[r, c] == 0:
                        c += 1
                    out.append((x + start * step, y + r * step, x + c * step, y + (r + 1) * step))
                else:
                    c += 1
    return np.array(out, np.float64).reshape(-1, 4)
