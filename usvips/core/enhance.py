"""Image enhancement as a non-destructive pipeline (thesis 3.4.3), and stereo brightness balancing.

A :class:`Pipeline` is an ordered list of :class:`Operation` (a name and its parameters), applied to the
original image every time; it serialises to JSON. Images are numpy arrays, uint8 or uint16, grey
(H, W) or RGB (H, W, 3); every operation returns the same dtype and shape and never moves a pixel, so
pixel coordinates always refer to the original. Intensities in parameters are in the image's own units
(0-255 for 8-bit, 0-65535 for 16-bit) unless stated as a fraction.

Operations (name: parameters):

* ``brightness``: offset (intensity units, added)
* ``linear_stretch``: saturation (percent of pixels clipped, split between both ends; default 1)
* ``piecewise``: points — [[in, out], ...] breakpoints in intensity units, ``in`` increasing
* ``equalize``: — (histogram equalisation; colour images on their luminance)
* ``clahe``: clip_limit (default 2), tiles (default 8) — contrast-limited adaptive equalisation
* ``gamma``: gamma > 0 (out = max·(in/max)^gamma; < 1 brightens)
* ``sobel``: strength (adds strength × the Sobel gradient magnitude)
* ``laplacian``: strength (subtracts strength × the Laplacian: sharpening)
* ``knn``: k in 1..8 (Davis & Rosenfeld: mean of the pixel and the k of its 8 neighbours closest to it in
  grey level — removes isolated noise, keeps edges)
* ``mean``: size (odd), ``median``: size (odd)
* ``convolve``: kernel (odd × odd list of lists), normalise (divide by the sum when it is not 0)
* ``white_balance``: method ``grey-world`` or ``patch`` with patch [x0, y0, x1, y1] (pixels) that should
  be neutral grey (colour images only)
* ``levels``: gain, offset (out = gain·in + offset; what :func:`balance_pair` produces)
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np

from usvips.core.errors import InvalidParameterError

SUPPORTED = (np.uint8, np.uint16)


def check_image(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Raise :class:`InvalidParameterError` unless ``image`` is uint8/uint16, (H, W) or (H, W, 3)."""
    image = np.asarray(image)
    if image.dtype not in SUPPORTED:
        raise InvalidParameterError(name, f"unsupported pixel type {image.dtype}; use 8- or 16-bit images")
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3) or min(image.shape[:2]) == 0:
        raise InvalidParameterError(name, f"must be grey (H, W) or colour (H, W, 3), got shape {image.shape}")
    return image


def luminance(image: np.ndarray) -> np.ndarray:
    """Grey values as float32 (H, W): a grey image as it is, a colour one by the BT.601 weights
    (0.299, 0.587, 0.114) without rounding."""
    image = check_image(image)
    if image.ndim == 3:
        return cv2.cvtColor(np.ascontiguousarray(image, dtype=np.float32), cv2.COLOR_RGB2GRAY)
    return np.ascontiguousarray(image, dtype=np.float32)


def _maximum(image: np.ndarray) -> int:
    return int(np.iinfo(image.dtype).max)


def _apply_lut(image: np.ndarray, lut: np.ndarray) -> np.ndarray:
    """Map intensities through a lookup table of the dtype's full range (float values, clipped)."""
    top = _maximum(image)
    table = np.clip(np.rint(lut), 0, top).astype(image.dtype)
    if image.dtype == np.uint8:
        return cv2.LUT(image, table)
    return table[image]


def _clip_to(image: np.ndarray, values: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(values), 0, _maximum(image)).astype(image.dtype)


def _luminance_op(image: np.ndarray, function: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Apply a single-channel operation to a grey image, or to a colour image's luminance (YCrCb)."""
    if image.ndim == 2:
        return function(image)
    if image.dtype == np.uint8:
        ycc = cv2.cvtColor(image, cv2.COLOR_RGB2YCrCb)
        ycc[:, :, 0] = function(np.ascontiguousarray(ycc[:, :, 0]))
        return cv2.cvtColor(ycc, cv2.COLOR_YCrCb2RGB)
    # 16-bit colour: scale the channels by the luminance change (keeps hue)
    luminance = image.astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)
    lum16 = _clip_to(image, luminance)
    changed = function(lum16).astype(np.float32)
    ratio = changed / np.maximum(luminance, 1.0)
    return _clip_to(image, image.astype(np.float32) * ratio[:, :, None])


# --- point operations --------------------------------------------------------------------------

def brightness(image: np.ndarray, offset: float) -> np.ndarray:
    return _apply_lut(image, np.arange(_maximum(image) + 1, dtype=np.float64) + offset)


def levels(image: np.ndarray, gain: float, offset: float = 0.0) -> np.ndarray:
    return _apply_lut(image, np.arange(_maximum(image) + 1, dtype=np.float64) * gain + offset)


def linear_stretch(image: np.ndarray, saturation: float = 1.0) -> np.ndarray:
    low, high = np.percentile(image, [saturation / 2.0, 100.0 - saturation / 2.0])
    if high <= low:
        return image.copy()
    top = _maximum(image)
    return _apply_lut(image, (np.arange(top + 1, dtype=np.float64) - low) * top / (high - low))


def piecewise(image: np.ndarray, points: list[list[float]]) -> np.ndarray:
    knots = np.asarray(points, dtype=np.float64)
    return _apply_lut(image, np.interp(np.arange(_maximum(image) + 1), knots[:, 0], knots[:, 1]))


def gamma(image: np.ndarray, gamma: float) -> np.ndarray:
    top = _maximum(image)
    return _apply_lut(image, top * (np.arange(top + 1, dtype=np.float64) / top) ** gamma)


def _equalize_channel(channel: np.ndarray) -> np.ndarray:
    if channel.dtype == np.uint8:
        return cv2.equalizeHist(channel)
    top = _maximum(channel)
    counts = np.bincount(channel.ravel(), minlength=top + 1)
    cdf = np.cumsum(counts).astype(np.float64)
    first = cdf[np.flatnonzero(counts)[0]]
    if cdf[-1] == first:
        return channel.copy()
    lut = (cdf - first) / (cdf[-1] - first) * top
    return _apply_lut(channel, lut)


def equalize(image: np.ndarray) -> np.ndarray:
    return _luminance_op(image, _equalize_channel)


def clahe(image: np.ndarray, clip_limit: float = 2.0, tiles: int = 8) -> np.ndarray:
    operator = cv2.createCLAHE(clipLimit=float(clip_limit), tileGridSize=(int(tiles), int(tiles)))
    return _luminance_op(image, lambda channel: operator.apply(channel))


# --- neighbourhood operations -------------------------------------------------------------------

def _per_channel(image: np.ndarray, function: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    if image.ndim == 2:
        return function(image)
    return np.stack([function(np.ascontiguousarray(image[:, :, c])) for c in range(3)], axis=2)


def sobel(image: np.ndarray, strength: float = 1.0) -> np.ndarray:
    def one(channel: np.ndarray) -> np.ndarray:
        data = channel.astype(np.float32)
        gx = cv2.Sobel(data, cv2.CV_32F, 1, 0, ksize=3, borderType=cv2.BORDER_REFLECT)
        gy = cv2.Sobel(data, cv2.CV_32F, 0, 1, ksize=3, borderType=cv2.BORDER_REFLECT)
        return _clip_to(channel, data + strength * np.sqrt(gx * gx + gy * gy))
    return _per_channel(image, one)


def laplacian(image: np.ndarray, strength: float = 1.0) -> np.ndarray:
    def one(channel: np.ndarray) -> np.ndarray:
        data = channel.astype(np.float32)
        lap = cv2.Laplacian(data, cv2.CV_32F, ksize=1, borderType=cv2.BORDER_REFLECT)
        return _clip_to(channel, data - strength * lap)
    return _per_channel(image, one)


def knn(image: np.ndarray, k: int = 4) -> np.ndarray:
    def one(channel: np.ndarray) -> np.ndarray:
        padded = np.pad(channel.astype(np.float32), 1, mode="reflect")
        h, w = channel.shape
        centre = padded[1:-1, 1:-1]
        neighbours = np.stack([padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
                               for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dy, dx) != (0, 0)], axis=2)
        distance = np.abs(neighbours - centre[:, :, None])
        nearest = np.take_along_axis(neighbours, np.argsort(distance, axis=2, kind="stable")[:, :, :k], axis=2)
        return _clip_to(channel, (centre + nearest.sum(axis=2)) / (k + 1))
    return _per_channel(image, one)


def mean(image: np.ndarray, size: int = 3) -> np.ndarray:
    data = cv2.blur(image.astype(np.float32), (int(size), int(size)), borderType=cv2.BORDER_REFLECT)
    return _clip_to(image, data)


def median(image: np.ndarray, size: int = 3) -> np.ndarray:
    if image.dtype == np.uint8 or size <= 5:
        return cv2.medianBlur(image, int(size))
    from scipy import ndimage  # deferred: scipy.ndimage is slow to import (the window's start-up)

    footprint = (size, size) if image.ndim == 2 else (size, size, 1)
    return ndimage.median_filter(image, size=footprint, mode="reflect")


def convolve(image: np.ndarray, kernel: list[list[float]], normalise: bool = True) -> np.ndarray:
    mask = np.asarray(kernel, dtype=np.float32)
    total = float(mask.sum())
    if normalise and total != 0.0:
        mask = mask / total
    data = cv2.filter2D(image.astype(np.float32), cv2.CV_32F, mask, borderType=cv2.BORDER_REFLECT)
    return _clip_to(image, data)


def white_balance(image: np.ndarray, method: str = "grey-world", patch: list[int] | None = None) -> np.ndarray:
    if image.ndim != 3:
        raise InvalidParameterError("white_balance", "needs a colour image")
    data = image.astype(np.float64)
    if method == "patch":
        x0, y0, x1, y1 = (int(v) for v in patch)
        region = data[y0:y1 + 1, x0:x1 + 1].reshape(-1, 3)
    else:
        region = data.reshape(-1, 3)
    means = region.mean(axis=0)
    gains = means.mean() / np.maximum(means, 1e-9)
    return _clip_to(image, data * gains)


# --- the pipeline ---------------------------------------------------------------------------------

def _number(op: str, name: str, value, low: float = -np.inf, high: float = np.inf, odd: bool = False,
            integer: bool = False, open_low: bool = False) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{op}.{name}", f"{value!r} is not a number") from None
    if not np.isfinite(number) or number < low or number > high or (open_low and number <= low):
        bound = f"> {low:g}" if open_low else f"in [{low:g}, {high:g}]"
        raise InvalidParameterError(f"{op}.{name}", f"must be finite and {bound}, got {value!r}")
    if (integer or odd) and number != int(number):
        raise InvalidParameterError(f"{op}.{name}", f"must be a whole number, got {value!r}")
    if odd and int(number) % 2 == 0:
        raise InvalidParameterError(f"{op}.{name}", f"must be odd, got {int(number)}")
    return int(number) if (integer or odd) else number


def _validate(name: str, params: dict) -> dict:
    p = dict(params)
    if name == "brightness":
        return {"offset": _number(name, "offset", p.get("offset", 0.0), -65535, 65535)}
    if name == "levels":
        return {"gain": _number(name, "gain", p.get("gain", 1.0), 0, open_low=True),
                "offset": _number(name, "offset", p.get("offset", 0.0), -65535, 65535)}
    if name == "linear_stretch":
        return {"saturation": _number(name, "saturation", p.get("saturation", 1.0), 0, 50)}
    if name == "piecewise":
        points = p.get("points")
        try:
            knots = np.asarray(points, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidParameterError("piecewise.points", "must be a list of [in, out] pairs") from None
        if knots.ndim != 2 or knots.shape[1] != 2 or len(knots) < 2 or not np.all(np.isfinite(knots)):
            raise InvalidParameterError("piecewise.points", "needs at least two finite [in, out] pairs")
        if np.any(np.diff(knots[:, 0]) <= 0):
            raise InvalidParameterError("piecewise.points", "the 'in' values must increase")
        return {"points": knots.tolist()}
    if name == "equalize":
        return {}
    if name == "clahe":
        return {"clip_limit": _number(name, "clip_limit", p.get("clip_limit", 2.0), 0, 1000, open_low=True),
                "tiles": _number(name, "tiles", p.get("tiles", 8), 1, 256, integer=True)}
    if name == "gamma":
        return {"gamma": _number(name, "gamma", p.get("gamma", 1.0), 0, 100, open_low=True)}
    if name in ("sobel", "laplacian"):
        return {"strength": _number(name, "strength", p.get("strength", 1.0), -100, 100)}
    if name == "knn":
        return {"k": _number(name, "k", p.get("k", 4), 1, 8, integer=True)}
    if name in ("mean", "median"):
        return {"size": _number(name, "size", p.get("size", 3), 1, 255, odd=True)}
    if name == "convolve":
        try:
            kernel = np.asarray(p.get("kernel"), dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidParameterError("convolve.kernel", "must be a rectangular list of lists of numbers") from None
        if kernel.ndim != 2 or kernel.shape[0] % 2 == 0 or kernel.shape[1] % 2 == 0:
            raise InvalidParameterError("convolve.kernel", f"must be odd-sized (e.g. 3 × 3), got shape {kernel.shape}")
        if not np.all(np.isfinite(kernel)):
            raise InvalidParameterError("convolve.kernel", "must be finite")
        return {"kernel": kernel.tolist(), "normalise": bool(p.get("normalise", True))}
    if name == "white_balance":
        method = p.get("method", "grey-world")
        if method not in ("grey-world", "patch"):
            raise InvalidParameterError("white_balance.method", f"must be 'grey-world' or 'patch', got {method!r}")
        out = {"method": method}
        if method == "patch":
            patch = p.get("patch")
            if not isinstance(patch, list | tuple) or len(patch) != 4:
                raise InvalidParameterError("white_balance.patch", "must be [x0, y0, x1, y1] in pixels")
            out["patch"] = [int(_number(name, "patch", v, 0, integer=True)) for v in patch]
        return out
    raise InvalidParameterError("operation", f"unknown enhancement {name!r}; known: {', '.join(OPERATIONS)}")


OPERATIONS: dict[str, Callable[..., np.ndarray]] = {
    "brightness": brightness, "levels": levels, "linear_stretch": linear_stretch, "piecewise": piecewise,
    "equalize": equalize, "clahe": clahe, "gamma": gamma, "sobel": sobel, "laplacian": laplacian, "knn": knn,
    "mean": mean, "median": median, "convolve": convolve, "white_balance": white_balance,
}

PARAMETERS: dict[str, set[str]] = {
    "brightness": {"offset"}, "levels": {"gain", "offset"}, "linear_stretch": {"saturation"},
    "piecewise": {"points"}, "equalize": set(), "clahe": {"clip_limit", "tiles"}, "gamma": {"gamma"},
    "sobel": {"strength"}, "laplacian": {"strength"}, "knn": {"k"}, "mean": {"size"}, "median": {"size"},
    "convolve": {"kernel", "normalise"}, "white_balance": {"method", "patch"},
}


@dataclass(frozen=True)
class Operation:
    """One enhancement step: ``name`` and its validated ``params``."""

    name: str
    params: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.params, dict):
            raise InvalidParameterError(self.name, "parameters must be a mapping")
        if self.name not in OPERATIONS:
            raise InvalidParameterError("operation", f"unknown enhancement {self.name!r}; "
                                        f"known: {', '.join(OPERATIONS)}")
        unknown = set(self.params) - PARAMETERS[self.name]
        if unknown:
            raise InvalidParameterError(self.name, f"unknown parameter(s) {', '.join(sorted(unknown))}")
        object.__setattr__(self, "params", _validate(self.name, self.params))

    def apply(self, image: np.ndarray) -> np.ndarray:
        if self.name == "white_balance" and image.ndim != 3:
            raise InvalidParameterError("white_balance", "needs a colour image")
        if self.name == "white_balance" and self.params.get("method") == "patch":
            x0, y0, x1, y1 = self.params["patch"]
            h, w = image.shape[:2]
            if not (0 <= x0 <= x1 < w and 0 <= y0 <= y1 < h):
                raise InvalidParameterError("white_balance.patch", f"{self.params['patch']} is outside the "
                                            f"{w} × {h} image")
        return OPERATIONS[self.name](image, **self.params)


@dataclass(frozen=True)
class Pipeline:
    """An ordered list of operations, applied to the original image; pure (the input is not changed)."""

    operations: tuple[Operation, ...] = ()

    def apply(self, image: np.ndarray) -> np.ndarray:
        image = check_image(image)
        out = image
        for operation in self.operations:
            out = operation.apply(out)
        return out if out is not image else image.copy()

    def then(self, name: str, **params) -> Pipeline:
        return Pipeline(self.operations + (Operation(name, params),))

    def to_json(self) -> str:
        return json.dumps([{"op": o.name, **o.params} for o in self.operations])

    @classmethod
    def from_json(cls, text: str) -> Pipeline:
        try:
            items = json.loads(text)
        except json.JSONDecodeError as error:
            raise InvalidParameterError("pipeline", f"not valid JSON: {error.msg}") from None
        if not isinstance(items, list) or not all(isinstance(i, dict) and "op" in i for i in items):
            raise InvalidParameterError("pipeline", "must be a list of {\"op\": name, ...parameters}")
        return cls(tuple(Operation(i["op"], {k: v for k, v in i.items() if k != "op"}) for i in items))


def balance_pair(left: np.ndarray, right: np.ndarray) -> Operation:
    """A ``levels`` operation that gives the right image the left one's mean and standard deviation
    (brightness balancing of a stereo pair, thesis 3.4.3)."""
    left, right = check_image(left, "left"), check_image(right, "right")
    mean_l, std_l = float(left.mean()), float(left.std())
    mean_r, std_r = float(right.mean()), float(right.std())
    gain = std_l / std_r if std_r > 0 else 1.0
    return Operation("levels", {"gain": gain, "offset": mean_l - gain * mean_r})


def histogram(image: np.ndarray, bins: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Counts per channel (C, bins) over the dtype's full range, and the bin edges (bins + 1,)."""
    image = check_image(image)
    top = _maximum(image)
    if int(bins) < 1:
        raise InvalidParameterError("bins", f"must be >= 1, got {bins}")
    edges = np.linspace(0, top + 1, int(bins) + 1)
    channels = image[:, :, None] if image.ndim == 2 else image
    counts = np.stack([np.histogram(channels[:, :, c], bins=edges)[0] for c in range(channels.shape[2])])
    return counts, edges
