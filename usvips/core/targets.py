"""Sub-pixel pointing: the centre of a circular target or of a cross near a click (thesis 4.2, rec. 4).

Pixel convention: x right, y down, origin at the centre of the top-left pixel (``image[row, col]`` is
at x = col, y = row). Every finder returns a :class:`TargetResult`, falsy when it refuses, with the
reason (no target, two targets, clipped at the window or image edge).

* Disc (the thesis's targets: 8 cm white discs, with a black-and-white cross inside, 3.3.3): the disc is
  segmented at half its contrast, its holes filled (so the inner cross does not matter), and its centre
  is the centroid of its *coverage*: 1 inside, and along the edge band the fraction of the pixel the
  disc covers, read from the intensity between background and disc levels. Unbiased for blurred and
  perspective-distorted (elliptical) discs to a few hundredths of a pixel; noise averages out along the
  edge.
* Cross: normalised cross-correlation with a synthetic cross template of either polarity, and a
  quadratic fit of the correlation peak.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from usvips.core.enhance import check_image, luminance
from usvips.core.errors import InvalidParameterError


@dataclass(frozen=True)
class TargetResult:
    """``center`` (x, y) pixels; ``quality``: contrast-to-noise (disc) or the correlation peak (cross);
    ``radius`` (px, disc: of the equal-area circle); ``reason`` when it refused (then falsy)."""

    center: tuple[float, float] | None
    quality: float
    reason: str = ""
    radius: float = 0.0

    def __bool__(self) -> bool:
        return self.center is not None


def _window(image: np.ndarray, click: tuple[float, float], half: int) -> tuple[np.ndarray, int, int] | None:
    h, w = image.shape[:2]
    x, y = float(click[0]), float(click[1])
    if not (np.isfinite(x) and np.isfinite(y)) or not (-0.5 <= x < w - 0.5 and -0.5 <= y < h - 0.5):
        raise InvalidParameterError("click", f"({x:g}, {y:g}) is outside the {w} × {h} image")
    col, row = int(round(x)), int(round(y))
    if row - half < 0 or col - half < 0 or row + half >= h or col + half >= w:
        return None
    return image[row - half:row + half + 1, col - half:col + half + 1], row - half, col - half


def _ellipse_overlap(blob: np.ndarray) -> float:
    """Intersection over union of a region and the ellipse fitted to its outline (1 for an ellipse)."""
    contours, _ = cv2.findContours(blob.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(contours, key=len)
    if len(outline) < 5:
        return 0.0
    (cx, cy), (width, height), angle = cv2.fitEllipse(outline)
    scale = 16  # draw with sub-pixel precision
    ellipse = np.zeros(blob.shape, np.uint8)
    cv2.ellipse(ellipse, (int(round(cx * scale)), int(round(cy * scale))),
                (int(round(width * scale / 2)), int(round(height * scale / 2))), angle, 0, 360, 1, -1,
                cv2.LINE_8, 4)
    inter = np.logical_and(blob, ellipse).sum()
    union = np.logical_or(blob, ellipse).sum()
    return float(inter / union) if union else 0.0


def locate_disc(image: np.ndarray, click: tuple[float, float], window: int = 41) -> TargetResult:
    """Centre of the bright (or dark) disc nearest the click within a ``window`` × ``window`` patch."""
    half = int(window) // 2
    if half < 3:
        raise InvalidParameterError("window", f"must be at least 7 pixels, got {window}")
    cut = _window(check_image(image), click, half)
    if cut is None:
        return TargetResult(None, 0.0, "clipped: the window around the click reaches the image edge")
    patch, top, left = cut
    patch = luminance(patch)  # only the window: a full 4000 × 3000 conversion would cost more than the fit
    ring = np.concatenate([patch[0], patch[-1], patch[:, 0], patch[:, -1]])
    background = float(np.median(ring))
    # pixel noise from neighbour differences along the ring: a smooth textured background does not count
    steps = np.concatenate([np.diff(patch[0]), np.diff(patch[-1]), np.diff(patch[:, 0]), np.diff(patch[:, -1])])
    noise = float(1.4826 * np.median(np.abs(steps)) / np.sqrt(2.0)) + 0.5
    # a white disc with a black cross is bright: decide the polarity by the stronger departure from the
    # background, not by the pixel under the click (which may sit on the cross)
    bright = float(np.percentile(patch, 99)) - background >= background - float(np.percentile(patch, 1))
    signal = patch - background if bright else background - patch
    level = float(np.percentile(signal, 99))
    if level < 6 * noise:
        return TargetResult(None, level / noise, "no target: too little contrast around the click")
    from scipy import ndimage  # deferred: scipy.ndimage is slow to import (the window's start-up)

    # close gaps a few pixels wide, so that a cross cutting through the disc does not split it
    mask = ndimage.binary_closing(signal > level / 2, structure=np.ones((5, 5), bool), border_value=0)
    labels, count = ndimage.label(mask)
    if count == 0:
        return TargetResult(None, level / noise, "no target near the click")
    sizes = ndimage.sum(mask, labels, np.arange(1, count + 1))
    ys, xs = np.mgrid[0:patch.shape[0], 0:patch.shape[1]]
    distances = []
    for k in range(1, count + 1):
        member = labels == k
        distances.append(float(np.min(np.hypot(xs[member] - half, ys[member] - half))))
    distances = np.array(distances)
    candidates = np.flatnonzero((sizes >= 12) & (distances <= half / 2))
    if candidates.size == 0:
        return TargetResult(None, level / noise, "no target near the click")
    best = candidates[np.argmin(distances[candidates])]
    others = [k for k in candidates if k != best and sizes[k] > 0.3 * sizes[best]]
    if others:
        return TargetResult(None, level / noise, "two targets near the click: click closer to one")
    blob = ndimage.binary_fill_holes(labels == best + 1)
    edge = np.zeros_like(blob)
    edge[0, :] = edge[-1, :] = edge[:, 0] = edge[:, -1] = True
    grown = ndimage.binary_dilation(blob, iterations=2)
    if np.any(grown & edge):
        return TargetResult(None, level / noise, "clipped: the target reaches the window edge; use a larger window")
    # a disc is an ellipse in the image; two targets run together are not (overlap ~0.77 for two touching)
    if _ellipse_overlap(blob) < 0.85:
        return TargetResult(None, level / noise, "two targets near the click (or not a disc): click closer to one")
    interior = ndimage.binary_erosion(blob, iterations=2)
    band = grown & ~interior
    coverage = interior.astype(np.float64)
    coverage[band] = np.clip(signal[band] / level, 0.0, 1.0)
    total = coverage.sum()
    cx = float((coverage * xs).sum() / total) + left
    cy = float((coverage * ys).sum() / total) + top
    return TargetResult((cx, cy), level / noise, "", float(np.sqrt(total / np.pi)))


def cross_template(size: int, arm_width: float) -> np.ndarray:
    """A dark cross (arms along x and y) on a light square, supersampled, values in [0, 1]."""
    s = 4
    coords = (np.arange(size * s) + 0.5) / s - size / 2
    xs, ys = np.meshgrid(coords, coords)
    inside = (np.abs(xs) < arm_width / 2) | (np.abs(ys) < arm_width / 2)
    return 1.0 - inside.reshape(size, s, size, s).mean(axis=(1, 3)).astype(np.float32)


def locate_cross(image: np.ndarray, click: tuple[float, float], window: int = 41, template_size: int = 15,
                 arm_width: float = 3.0) -> TargetResult:
    """Centre of a cross (dark on light or light on dark) near the click, by correlation."""
    half = int(window) // 2
    size = int(template_size) | 1
    if size >= window:
        raise InvalidParameterError("template_size", f"must be smaller than the window ({window}), got {size}")
    cut = _window(check_image(image), click, half)
    if cut is None:
        return TargetResult(None, 0.0, "clipped: the window around the click reaches the image edge")
    patch, top, left = cut
    patch = luminance(patch)  # only the window: a full 4000 × 3000 conversion would cost more than the fit
    if float(patch.std()) < 1e-3:
        return TargetResult(None, 0.0, "no target: the patch is uniform")
    template = cross_template(size, arm_width)
    score = cv2.matchTemplate(patch, template, cv2.TM_CCOEFF_NORMED)
    if abs(score.min()) > score.max():
        score = -score  # a light cross on a dark ground
    offset = size // 2
    peak_y, peak_x = np.unravel_index(int(np.argmax(score)), score.shape)
    best = float(score[peak_y, peak_x])
    if best < 0.5:
        return TargetResult(None, best, "no cross near the click (correlation below 0.5)")
    if peak_y in (0, score.shape[0] - 1) or peak_x in (0, score.shape[1] - 1):
        return TargetResult(None, best, "clipped: the best match lies on the window edge")
    masked = score.copy()
    masked[max(0, peak_y - size // 2):peak_y + size // 2 + 1, max(0, peak_x - size // 2):peak_x + size // 2 + 1] = -1
    if masked.max() > 0.9 * best:
        return TargetResult(None, best, "two crosses near the click: click closer to one")
    around = score[peak_y - 1:peak_y + 2, peak_x - 1:peak_x + 2].astype(np.float64)
    dx = 0.5 * (around[1, 0] - around[1, 2]) / (around[1, 0] - 2 * around[1, 1] + around[1, 2])
    dy = 0.5 * (around[0, 1] - around[2, 1]) / (around[0, 1] - 2 * around[1, 1] + around[2, 1])
    dx, dy = float(np.clip(dx, -0.5, 0.5)), float(np.clip(dy, -0.5, 0.5))
    return TargetResult((left + peak_x + offset + dx, top + peak_y + offset + dy), best)
