"""Conjugate matching along the refractive epipolar curve (thesis 4.2, recommendation 7).

Behind a housing the rays of one camera do not image as a straight line in the other: the epipolar
"line" is a curve. :func:`epipolar_curve` samples the source pixel's ray in the water at depths and
back-projects each sample into the other camera. :func:`match_along_curve` slides a template of the
source image along that curve by normalised cross-correlation, refines the best position in 2-D to
sub-pixel precision, and reports ambiguity (a second, separate peak nearly as good), textureless
templates and a best correlation below ``min_score`` as refusals. A refusal still carries the best
candidate on the curve when there is one, marked ``weak`` with its score and why (a weak proposal that
the user can accept with one key or correct); only a blank template or a curve outside the image give
no candidate at all. Pixels: x right, y down, origin at the centre of the top-left pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from usvips.core import validation
from usvips.core.camera import Camera
from usvips.core.enhance import check_image, luminance
from usvips.core.errors import InvalidParameterError


@dataclass(frozen=True)
class EpipolarCurve:
    """``pixels`` (M, 2) in the other image, ordered by ``depths`` (M,) metres along the source ray in
    the water; only samples the other camera sees (inside its frame when its size is known)."""

    pixels: np.ndarray
    depths: np.ndarray

    def distance_to(self, point: np.ndarray) -> float:
        """Shortest distance (pixels) from a pixel to the curve (as a polyline)."""
        point = np.asarray(point, dtype=np.float64)
        if len(self.pixels) == 0:
            return float("inf")
        if len(self.pixels) == 1:
            return float(np.linalg.norm(self.pixels[0] - point))
        a, b = self.pixels[:-1], self.pixels[1:]
        ab = b - a
        t = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
        return float(np.min(np.linalg.norm(a + t[:, None] * ab - point, axis=1)))


def epipolar_curve(source: Camera, target: Camera, pixel, near: float = 0.3, far: float = 10.0,
                   samples: int = 200) -> EpipolarCurve:
    """The refractive epipolar curve in ``target`` of ``pixel`` (x, y) of ``source`` for water depths
    from ``near`` to ``far`` metres along the ray (geometrically spaced)."""
    pixel = validation.finite_vector("pixel", pixel, 2)
    near = validation.positive("near", near)
    far = validation.positive("far", far)
    if far <= near:
        raise InvalidParameterError("far", f"must exceed near ({near:g} m), got {far:g}")
    return epipolar_curve_at(source, target, pixel, np.geomspace(near, far, int(samples)))


def epipolar_curve_at(source: Camera, target: Camera, pixel: np.ndarray, depths: np.ndarray) -> EpipolarCurve:
    """:func:`epipolar_curve` at given ``depths`` (M,) metres along the ray in the water, increasing, for a
    finite ``pixel`` (2,): a tracker asking for the curve of a new pixel every frame makes its depths once."""
    bundle = source.rays(pixel[None, :])
    if not bundle.ok[0]:
        return EpipolarCurve(np.zeros((0, 2)), np.zeros(0))
    points = bundle.origins[0] + depths[:, None] * bundle.directions[0]
    projection = target.project(points)
    keep = projection.ok
    return EpipolarCurve(projection.pixels[keep], depths[keep])


@dataclass(frozen=True)
class MatchResult:
    """``pixel`` (x, y) in the other image, ``score`` (NCC, −1..1), ``depth`` (m along the source ray),
    ``ambiguous`` with ``reason`` when a second, separate peak scores nearly as well; ``weak`` (with
    ``reason``) when the match was refused (ambiguous, textureless, a low score) but ``pixel`` is still the
    best candidate on the curve. Truthy only for a confident match; :attr:`proposal` is the pixel to
    propose either way (None when there is no candidate)."""

    pixel: tuple[float, float] | None
    score: float
    depth: float | None
    ambiguous: bool = False
    reason: str = ""
    weak: bool = False

    def __bool__(self) -> bool:
        return self.pixel is not None and not self.ambiguous and not self.weak

    @property
    def proposal(self) -> tuple[float, float] | None:
        """The candidate to propose: the match, or the best weak candidate; None when there is none."""
        return self.pixel

    def describe(self) -> str:
        """One line for the status bar: the correlation, and why a proposal is weak."""
        if self.pixel is None:
            return f"no candidate: {self.reason}"
        if self.weak or self.ambiguous:
            return f"weak proposal (correlation {self.score:.2f}): {self.reason}"
        return f"proposed match (correlation {self.score:.2f})"


def _resample(curve: EpipolarCurve, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points along the curve every ``spacing`` pixels, with interpolated depths."""
    steps = np.linalg.norm(np.diff(curve.pixels, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(steps)])
    if arc[-1] == 0:
        return curve.pixels[:1], curve.depths[:1]
    s = np.arange(0.0, arc[-1] + 1e-9, spacing)
    x = np.interp(s, arc, curve.pixels[:, 0])
    y = np.interp(s, arc, curve.pixels[:, 1])
    return np.column_stack([x, y]), np.interp(s, arc, curve.depths)


def match_along_curve(source_image: np.ndarray, target_image: np.ndarray, pixel, curve: EpipolarCurve,
                      window: int = 15, min_contrast: float = 4.0, ambiguity: float = 0.9,
                      min_score: float = 0.5) -> MatchResult:
    """Find the conjugate of ``pixel`` along ``curve`` by normalised cross-correlation.

    window: template size (odd, pixels); min_contrast: the template's standard deviation (grey levels)
    below which it is textureless and refused; ambiguity: a second peak at least ``window`` pixels away
    scoring above this fraction of the best makes the match ambiguous; min_score: the correlation below
    which the best candidate is refused. Every refusal with a candidate returns it, ``weak``.
    """
    if not -1.0 <= float(min_score) < 1.0:
        raise InvalidParameterError("min_score", f"must lie in [-1, 1), got {min_score}")
    window = int(window)
    if window < 5 or window % 2 == 0:
        raise InvalidParameterError("window", f"must be odd and >= 5, got {window}")
    source_image, target_image = check_image(source_image, "source"), check_image(target_image, "target")
    x, y = validation.finite_vector("pixel", pixel, 2)
    h, w = source_image.shape[:2]
    half = window // 2
    if not (half <= x <= w - 1 - half and half <= y <= h - 1 - half):
        raise InvalidParameterError("pixel", f"({x:g}, {y:g}) is too close to the edge of the {w} × {h} image "
                                    f"for a {window} px template")
    # grey only the regions used (a whole 4000 × 3000 colour image would cost more than the search)
    sx0, sy0 = max(int(x) - half - 2, 0), max(int(y) - half - 2, 0)
    source = luminance(source_image[sy0:int(y) + half + 3, sx0:int(x) + half + 3])
    template = cv2.getRectSubPix(source, (window, window), (float(x - sx0), float(y - sy0)))
    textureless = ""
    if float(template.std()) < min_contrast:
        textureless = (f"textureless: the template's contrast ({template.std():.1f}) is below {min_contrast:g} "
                       "grey levels")
        if float(template.std()) < 0.5:  # blank: no correlation to rank candidates by
            return MatchResult(None, 0.0, None, False, textureless)
    if len(curve.pixels) == 0:
        return MatchResult(None, 0.0, None, False, "the epipolar curve does not enter the other image")
    th, tw = target_image.shape[:2]
    samples, depths = _resample(curve, 1.0)
    inside = ((samples[:, 0] >= half + 2) & (samples[:, 0] <= tw - 3 - half)
              & (samples[:, 1] >= half + 2) & (samples[:, 1] <= th - 3 - half))
    samples, depths = samples[inside], depths[inside]
    if len(samples) == 0:
        return MatchResult(None, 0.0, None, False, "the epipolar curve runs outside the other image")
    # correlation over the curve's bounding box in one call, read off at the curve's samples
    x0 = int(np.floor(samples[:, 0].min())) - half
    y0 = int(np.floor(samples[:, 1].min())) - half
    x1 = int(np.ceil(samples[:, 0].max())) + half + 1
    y1 = int(np.ceil(samples[:, 1].max())) + half + 1
    # the grey target region: the box plus the margin of the 2-D refinement below
    cx0, cy0 = max(x0 - 4, 0), max(y0 - 4, 0)
    target = luminance(target_image[cy0:min(y1 + 5, th), cx0:min(x1 + 5, tw)])
    surface = cv2.matchTemplate(np.ascontiguousarray(target[y0 - cy0:y1 + 1 - cy0, x0 - cx0:x1 + 1 - cx0]), template,
                                cv2.TM_CCOEFF_NORMED)
    map_x = (samples[:, 0] - x0 - half).astype(np.float32).reshape(1, -1)
    map_y = (samples[:, 1] - y0 - half).astype(np.float32).reshape(1, -1)
    scores = cv2.remap(surface, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE).ravel()
    best = int(np.argmax(scores))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(samples, axis=0), axis=1))])
    far_away = np.abs(arc - arc[best]) > window
    second = float(scores[far_away].max()) if far_away.any() else -1.0
    # refine in 2-D around the best sample: correlation on a 7 x 7 grid, quadratic peak
    u0, v0 = samples[best]
    region = cv2.getRectSubPix(target, (window + 6, window + 6), (float(u0 - cx0), float(v0 - cy0)))
    surface = cv2.matchTemplate(region, template, cv2.TM_CCOEFF_NORMED)
    py, px = np.unravel_index(int(np.argmax(surface)), surface.shape)
    peak = float(surface[py, px])
    dx = dy = 0.0
    if 0 < px < surface.shape[1] - 1:
        denominator = surface[py, px - 1] - 2 * peak + surface[py, px + 1]
        dx = 0.5 * (surface[py, px - 1] - surface[py, px + 1]) / denominator if denominator < 0 else 0.0
    if 0 < py < surface.shape[0] - 1:
        denominator = surface[py - 1, px] - 2 * peak + surface[py + 1, px]
        dy = 0.5 * (surface[py - 1, px] - surface[py + 1, px]) / denominator if denominator < 0 else 0.0
    matched = (float(u0 + px - 3 + np.clip(dx, -0.5, 0.5)), float(v0 + py - 3 + np.clip(dy, -0.5, 0.5)))
    depth = float(depths[best])
    if textureless:
        return MatchResult(matched, peak, depth, False, textureless, weak=True)
    if second > ambiguity * max(peak, 1e-9):
        return MatchResult(matched, peak, depth, True,
                           f"ambiguous: a second peak {second:.2f} against {peak:.2f} elsewhere on the curve", True)
    if peak < min_score:
        return MatchResult(matched, peak, depth, False, f"the best correlation {peak:.2f} is below {min_score:.2f}",
                           True)
    return MatchResult(matched, peak, depth)
