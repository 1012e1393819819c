"""Ray-traced rendering of simple underwater scenes through any camera (pinhole, flat port, dome cover).

Every pixel is sampled ``supersample`` × ``supersample`` times; each sample's ray is traced through the
housing (``Camera.rays``) into the scene: target discs (white, with a black cross, facing a given
direction — the thesis's calibration targets) and a textured seafloor plane. Underwater the light from
a surface at water path length L is attenuated and veiled by backscatter,
I = J·exp(−c·L) + B·(1 − exp(−c·L)), then the image is blurred and noise is added. Grey, 8-bit.
Object space in metres; pixels in the usual convention (x right, y down, centre of the top-left pixel
at (0, 0)). Deterministic for a given ``seed``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np
from scipy.ndimage import map_coordinates

from usvips.core import validation
from usvips.core.camera import Camera


class SceneObject(Protocol):
    """Anything with ``hit(origins, directions) -> (t, grey)`` and a ``colour`` tint."""

    colour: tuple[float, float, float]

    def hit(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class Disc:
    """A flat circular target: centre (m), unit normal towards the cameras, radius (m); a black cross
    of arms ``cross_width`` (m) wide reaching ``cross_extent`` × radius from the centre."""

    centre: tuple[float, float, float]
    normal: tuple[float, float, float]
    radius: float = 0.04
    cross_width: float = 0.008
    cross_extent: float = 0.6
    brightness: float = 230.0
    cross_brightness: float = 25.0

    def __post_init__(self) -> None:
        validation.finite_vector("disc centre", self.centre, 3)
        normal = validation.finite_vector("disc normal", self.normal, 3)
        if np.linalg.norm(normal) == 0:
            raise validation.InvalidParameterError("disc normal", "must not be zero")
        validation.positive("disc radius", self.radius)


@dataclass(frozen=True)
class Seafloor:
    """The plane through ``point`` with ``normal``, textured with smooth random values every ``cell`` m."""

    point: tuple[float, float, float]
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    cell: float = 0.03
    mean: float = 110.0
    contrast: float = 60.0
    seed: int = 0


@dataclass(frozen=True)
class Water:
    """Attenuation coefficient c (1/m) and backscatter level B (grey), blur (pixels), noise (grey)."""

    attenuation: float = 0.25
    backscatter: float = 70.0
    blur: float = 0.7
    noise: float = 2.0
    #: Colour mode: attenuation (1/m) and backscatter per channel (red, green, blue); ``None`` derives them
    #: from the grey values with red absorbed most, as in coastal water.
    attenuation_rgb: tuple[float, float, float] | None = None
    backscatter_rgb: tuple[float, float, float] | None = None

    def channels(self, colour: bool) -> tuple[np.ndarray, np.ndarray]:
        """Attenuation (1/m) and backscatter (grey) as arrays of 1 (grey) or 3 (colour) channels."""
        if not colour:
            return np.array([self.attenuation]), np.array([self.backscatter])
        attenuation = self.attenuation_rgb or tuple(self.attenuation * k for k in (2.2, 1.0, 0.85))
        backscatter = self.backscatter_rgb or tuple(self.backscatter * k for k in (0.35, 1.0, 0.95))
        return np.asarray(attenuation, float), np.asarray(backscatter, float)


def _basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def render(camera: Camera, discs: list[Disc] = (), floor: Seafloor | None = None, water: Water | None = None,
           size: tuple[int, int] | None = None, supersample: int = 3, background: float = 60.0,
           seed: int = 0, objects: Sequence[SceneObject] = (), colour: bool = False, lighting: float = 0.0,
           interlace: float = 0.0) -> np.ndarray:
    """Render the scene as ``camera`` sees it: grey uint8 (height, width), or RGB uint8 (height, width, 3)
    with ``colour``. ``objects`` are fish, pipes, rocks (:mod:`usvips.core.synth.objects`). ``lighting``
    (0-1) darkens the image towards its corners as an artificial lamp does (1 − lighting·r², r = 1 at a
    corner); ``interlace`` shifts the odd rows by that many pixels to the right, as motion between the
    two fields of an interlaced video frame does."""
    width, height = size if size else (camera.width, camera.height)
    if not width or not height:
        raise validation.InvalidParameterError("size", "give the image size or a camera with width and height")
    s = int(supersample)
    ys, xs = np.mgrid[0:height * s, 0:width * s]
    pixels = np.column_stack([(xs.ravel() + 0.5) / s - 0.5, (ys.ravel() + 0.5) / s - 0.5])
    bundle = camera.rays(pixels)
    o, d = bundle.origins, bundle.directions
    nearest = np.full(len(pixels), np.inf)
    value = np.full(len(pixels), float(background))
    if floor is not None:
        n = np.asarray(floor.normal, float) / np.linalg.norm(floor.normal)
        denominator = d @ n
        t = np.where(np.abs(denominator) > 1e-12, ((np.asarray(floor.point) - o) @ n) / np.where(
            np.abs(denominator) > 1e-12, denominator, 1.0), np.inf)
        hit = (t > 0) & (t < nearest) & bundle.ok
        points = o[hit] + t[hit, None] * d[hit]
        u, v = _basis(n)
        grid = np.random.default_rng(floor.seed).uniform(-1, 1, (400, 400))
        rel = points - np.asarray(floor.point)
        texture = map_coordinates(grid, [rel @ v / floor.cell + 200, rel @ u / floor.cell + 200], order=3,
                                  mode="reflect")
        value[hit] = floor.mean + floor.contrast * texture
        nearest[hit] = t[hit]
    for disc in discs:
        n = np.asarray(disc.normal, float) / np.linalg.norm(disc.normal)
        c = np.asarray(disc.centre, float)
        denominator = d @ n
        safe = np.where(np.abs(denominator) > 1e-12, denominator, 1.0)
        t = np.where(np.abs(denominator) > 1e-12, ((c - o) @ n) / safe, np.inf)
        candidate = (t > 0) & (t < nearest) & bundle.ok
        points = o[candidate] + t[candidate, None] * d[candidate]
        u, v = _basis(n)
        a, b = (points - c) @ u, (points - c) @ v
        inside = a * a + b * b <= disc.radius**2
        index = np.flatnonzero(candidate)[inside]
        a, b = a[inside], b[inside]
        cross = ((np.abs(a) < disc.cross_width / 2) | (np.abs(b) < disc.cross_width / 2)) & (
            a * a + b * b < (disc.cross_extent * disc.radius) ** 2)
        value[index] = np.where(cross, disc.cross_brightness, disc.brightness)
        nearest[index] = t[index]
    tint = np.ones((len(pixels), 3)) if colour else None
    for element in objects:
        t, shade = element.hit(o, d)
        front = (t < nearest) & bundle.ok
        value[front] = shade[front]
        nearest[front] = t[front]
        if tint is not None:
            tint[front] = element.colour
    if colour:
        value = value[:, None] * tint
    if lighting:
        r2 = (((pixels[:, 0] - (width - 1) / 2) / (width / 2)) ** 2
              + ((pixels[:, 1] - (height - 1) / 2) / (height / 2)) ** 2) / 2
        falloff = 1 - float(lighting) * r2
        value = value * (falloff[:, None] if colour else falloff)
    if water is not None:
        path = np.where(np.isfinite(nearest), nearest, 50.0)
        attenuation, backscatter = water.channels(colour)
        if colour:
            transmission = np.exp(-attenuation[None, :] * path[:, None])
        else:
            attenuation, backscatter = attenuation[0], backscatter[0]
            transmission = np.exp(-attenuation * path)
        value = value * transmission + backscatter * (1 - transmission)
    channels = (3,) if colour else ()
    image = value.reshape(height, s, width, s, *channels).mean(axis=(1, 3))
    if water is not None:
        if water.blur > 0:
            image = cv2.GaussianBlur(image, (0, 0), water.blur)
        image = image + np.random.default_rng(seed).normal(0, water.noise, image.shape)
    if interlace:
        shifted = np.empty_like(image[1::2])
        columns = np.arange(width) - float(interlace)
        for row, line in enumerate(image[1::2]):
            if colour:
                shifted[row] = np.stack([np.interp(columns, np.arange(width), line[:, k]) for k in range(3)], axis=1)
            else:
                shifted[row] = np.interp(columns, np.arange(width), line)
        image[1::2] = shifted
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)
