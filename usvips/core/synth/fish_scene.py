"""Rendered fish with truth, for training and validating keypoint detectors: fish of varied body plans
(fusiform, deep-bodied, elongate), bent, sized, coloured and patterned, partly hidden behind rocks and weed
and each other, above a textured seabed, in turbid water with backscatter, blur, a colour cast and noise —
seen through any camera and housing kind, with the exact image positions of each fish's keypoints.

A fish is a flat mesh in body coordinates (u along the body in fork lengths, u = 0 at the snout tip and 1 at
the fork; b across it in fork lengths, dorsal positive). Its centre line may bend sideways (the tail swung
out of the body plane). Every mesh node is placed in object space (metres) and projected through the camera
(:meth:`usvips.core.camera.Camera.project`, refraction included), so the drawn fish and its keypoints are
the same projected points: the snout is the mesh's tip, the fork the vertex of the tail's notch, the caudal
tips the lobes' ends. The seabed is ray-traced on a coarse grid of pixels through the housing and the rest
interpolated. Quads are filled with OpenCV at twice the resolution and averaged down; the water's
attenuation and backscatter act on each pixel's path length. Vectorised: a 640 × 480 frame takes about
0.1-0.3 s (measured on a shared two-core machine). Pixels in the usual convention (x right, y down, origin
at the centre of the top-left pixel); object space in metres; the camera looks along its −Z axis.
Deterministic for a seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from usvips.core import housing as housings
from usvips.core.camera import Camera, Exterior
from usvips.core.detection.validation import TrueObject
from usvips.core.errors import InvalidParameterError
from usvips.core.interior import Interior
from usvips.core.rays import RayStatus

#: the keypoints each rendered fish carries, in this order
KEYPOINTS = ("snout", "fork", "upper caudal", "lower caudal")
#: the share of a fish's drawn area that must stay unhidden for a detector to be required to find it
REQUIRED_VISIBLE = 0.5
#: the shortest fish (snout to fork, image pixels) a detector is required to find: one pixel of pointing error
#: at each end is then at most 7 % of its length; a shorter fish is too small to measure
REQUIRED_LENGTH = 20.0

_SUPER = 2  # supersampling of the drawing (each axis)
_NU, _NB = 40, 8  # body mesh: quads along and across
_TIP = 0.012  # half-width of a caudal lobe's end (fork lengths): the caudal tip is its middle
_FAR = 1e3  # the path length (m) of a pixel that meets nothing: open water


@dataclass(frozen=True)
class BodyPlan:
    """A body plan in fork lengths: greatest ``depth`` and where it lies (``peak``), the caudal peduncle's
    position and half-height, the caudal fin's half-span at its tips and how far behind the fork its tips
    reach (``tail``), the blunting of the head (``bluntness``, 0.3 pointed … 0.8 blunt)."""

    name: str
    depth: tuple[float, float]
    peak: tuple[float, float]
    peduncle: tuple[float, float]
    peduncle_height: tuple[float, float]
    span: tuple[float, float]
    tail: tuple[float, float]
    bluntness: tuple[float, float]


#: the body plans scenes draw from (ranges; each fish draws its own values)
BODY_PLANS = (
    BodyPlan("fusiform", (0.20, 0.30), (0.30, 0.40), (0.84, 0.88), (0.030, 0.045), (0.11, 0.17), (0.10, 0.18),
             (0.45, 0.65)),
    BodyPlan("deep-bodied", (0.38, 0.55), (0.35, 0.45), (0.82, 0.87), (0.035, 0.055), (0.14, 0.22), (0.08, 0.16),
             (0.55, 0.80)),
    BodyPlan("elongate", (0.09, 0.15), (0.25, 0.45), (0.88, 0.92), (0.018, 0.028), (0.07, 0.11), (0.08, 0.14),
             (0.35, 0.55)),
)

_PATTERNS = ("plain", "bars", "stripes", "spots")


@dataclass(frozen=True)
class FishShape:
    """One fish's outline (fork lengths; see :class:`BodyPlan`), its colours (RGB 0-255 on back and belly),
    its pattern and how far the pattern darkens (0-1)."""

    plan: str
    depth: float
    peak: float
    peduncle: float
    peduncle_height: float
    span: float
    tail: float
    bluntness: float
    back: tuple[float, float, float]
    belly: tuple[float, float, float]
    pattern: str
    pattern_strength: float
    pattern_scale: float

    def half_height(self, u: np.ndarray) -> np.ndarray:
        """The body's half-height (fork lengths) at ``u`` (0 … peduncle), 0 at the snout tip."""
        u = np.clip(u, 0.0, self.peduncle)
        top = self.depth / 2
        a = self.bluntness
        front = top * np.clip(u / self.peak, 0, 1) ** a * (2 - np.clip(u / self.peak, 0, 1)) ** a / 1.0
        g = np.clip((self.peduncle - u) / (self.peduncle - self.peak), 0, 1)
        back = self.peduncle_height + (top - self.peduncle_height) * (3 * g**2 - 2 * g**3)
        return np.where(u <= self.peak, front, back)

    def fin_half_height(self, u: np.ndarray) -> np.ndarray:
        """The caudal fin's outer edge (fork lengths) from the peduncle to the tips."""
        end = 1.0 + self.tail
        s = np.clip((u - self.peduncle) / (end - self.peduncle), 0, 1)
        return self.peduncle_height + (self.span - self.peduncle_height) * s**1.3


@dataclass(frozen=True)
class SceneFish:
    """A fish placed in object space: the snout tip (m), the unit heading (snout → fork before bending),
    the unit dorsal direction, the fork length along the straight body (m), and the sideways bend (the tail's
    sideways offset at the fork as a fraction of the length; positive towards ``heading × up``)."""

    shape: FishShape
    snout: tuple[float, float, float]
    heading: tuple[float, float, float]
    up: tuple[float, float, float]
    length: float
    bend: float = 0.0

    def place(self, u: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Object points (…, 3) m of body coordinates (fork lengths)."""
        axis, up = np.asarray(self.heading, float), np.asarray(self.up, float)
        side = np.cross(axis, up)
        swing = self.bend * np.clip((u - 0.3) / 0.7, 0, None) ** 2
        along = u - 0.5 * swing**2  # the bent tail keeps its length (to first order)
        return (np.asarray(self.snout, float) + self.length * (along[..., None] * axis + swing[..., None] * side
                                                                + b[..., None] * up))

    def keypoint_points(self) -> np.ndarray:
        """The keypoints' object points (K, 3) m in the order of :data:`KEYPOINTS`."""
        s = self.shape
        end = 1.0 + s.tail
        return self.place(np.array([0.0, 1.0, end, end]), np.array([0.0, 0.0, s.span, -s.span]))


@dataclass(frozen=True)
class Occluder:
    """A weed frond or rock in front of the fish: a flat blob facing the camera, ``centre`` (m), ``radius``
    (m), a wobbly outline (``seed``) and a colour (RGB)."""

    centre: tuple[float, float, float]
    radius: float
    colour: tuple[float, float, float]
    elongation: float
    angle: float
    seed: int


@dataclass(frozen=True)
class FishScene:
    """Everything drawn in one frame: the fish, the occluders, the seabed (a point on it and its normal, or
    ``None`` for open water), the water (attenuation per channel 1/m, backscatter colour RGB), the blur
    (pixels), the noise (grey levels), the particles' count, the colour cast (gain per RGB channel) and the
    vignetting (0-1)."""

    fish: tuple[SceneFish, ...]
    occluders: tuple[Occluder, ...]
    seabed: tuple[tuple[float, float, float], tuple[float, float, float]] | None
    seabed_colour: tuple[float, float, float]
    attenuation: tuple[float, float, float]
    backscatter: tuple[float, float, float]
    blur: float
    noise: float
    particles: int
    cast: tuple[float, float, float]
    vignette: float
    seed: int


@dataclass(frozen=True)
class FishTruth:
    """One fish's truth in the image: ``keypoints`` (K, 2) pixels in the order of :data:`KEYPOINTS`, whether
    each is in the frame and not hidden by something nearer (``visible``, K), the box of its drawn pixels
    (x0, y0, x1, y1; NaN when none is drawn), the share of its drawn area that stays visible (0-1), its
    object points (K, 3) m and its body plan."""

    keypoints: np.ndarray
    visible: np.ndarray
    box: tuple[float, float, float, float]
    visible_fraction: float
    points: np.ndarray
    plan: str
    length: float

    @property
    def unhidden(self) -> bool:
        """Snout and fork visible and at least :data:`REQUIRED_VISIBLE` of the drawn area unhidden (what the
        training teaches as a fish, whatever its size)."""
        return bool(self.visible[0] and self.visible[1] and self.visible_fraction >= REQUIRED_VISIBLE)

    @property
    def length_pixels(self) -> float:
        """The snout–fork distance in the image (pixels)."""
        return float(np.hypot(*(self.keypoints[0] - self.keypoints[1])))

    @property
    def required(self) -> bool:
        """Whether a detector must find this fish: :attr:`unhidden` and at least :data:`REQUIRED_LENGTH`
        pixels from snout to fork."""
        return self.unhidden and self.length_pixels >= REQUIRED_LENGTH

    def true_object(self) -> TrueObject:
        """The fish as validation's truth (:mod:`usvips.core.detection.validation`), its drawn box the
        ignore region when it is not required."""
        box = self.box if np.all(np.isfinite(self.box)) else None
        return TrueObject({name: (float(x), float(y)) for name, (x, y) in zip(KEYPOINTS, self.keypoints, strict=True)},
                          self.required, box)


def _uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(rng.uniform(*bounds))


def random_shape(rng: np.random.Generator) -> FishShape:
    """A fish of a random body plan, colour and pattern."""
    plan = BODY_PLANS[int(rng.integers(len(BODY_PLANS)))]
    hue = rng.uniform(0, 1)
    base = np.array([0.55 + 0.45 * np.cos(2 * np.pi * (hue + k / 3)) for k in range(3)])
    light = rng.uniform(90, 230)
    back = np.clip(base * light * rng.uniform(0.45, 0.8), 10, 255)
    belly = np.clip(base * 0.4 * light + 0.6 * rng.uniform(150, 245), 20, 255)
    return FishShape(plan.name, _uniform(rng, plan.depth), _uniform(rng, plan.peak), _uniform(rng, plan.peduncle),
                     _uniform(rng, plan.peduncle_height), _uniform(rng, plan.span), _uniform(rng, plan.tail),
                     _uniform(rng, plan.bluntness), tuple(back), tuple(belly),
                     _PATTERNS[int(rng.integers(len(_PATTERNS)))], float(rng.uniform(0.2, 0.6)),
                     float(rng.uniform(4, 10)))


def _mesh(shape: FishShape) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int, int, int]]]:
    """Body-coordinate nodes (u, b) and the quads (node indices) of a fish: body, caudal fin (one piece to
    the fork, then two lobes), dorsal and anal fins."""
    us, bs, quads = [], [], []

    def grid(u: np.ndarray, lower: np.ndarray, upper: np.ndarray, across: int) -> None:
        start = sum(len(x) for x in us)
        t = np.linspace(0, 1, across + 1)
        us.append(np.repeat(u, across + 1))
        bs.append((lower[:, None] + (upper - lower)[:, None] * t[None, :]).ravel())
        n = across + 1
        for i in range(len(u) - 1):
            for j in range(across):
                a = start + i * n + j
                quads.append((a, a + 1, a + n + 1, a + n))

    u = shape.peduncle * (1 - np.cos(np.linspace(0, np.pi / 2, _NU + 1)))  # fine near the snout
    h = shape.half_height(u)
    grid(u, -h, h, _NB)
    u = np.linspace(shape.peduncle, 1.0, 5)
    h = shape.fin_half_height(u)
    grid(u, -h, h, _NB)
    end = 1.0 + shape.tail
    u = np.linspace(1.0, end, 7)
    outer = shape.fin_half_height(u) + _TIP * (u - 1.0) / shape.tail  # blunt lobe ends, 2 _TIP wide
    inner = (shape.span - _TIP) * (u - 1.0) / shape.tail
    grid(u, inner, outer, 3)
    grid(u, -outer, -inner, 3)
    for first, last, height, sign in ((0.35, 0.62, 0.35, 1), (0.6, 0.75, 0.22, -1)):
        u = np.linspace(first, last, 7)
        base = shape.half_height(u)
        top = base + height * shape.depth * np.sin(np.pi * (u - first) / (last - first)) ** 0.7 * (
            1 - 0.6 * (u - first) / (last - first))
        grid(u, sign * base * 0.97, sign * top, 1) if sign > 0 else grid(u, -top, -base * 0.97, 1)
    return np.concatenate(us), np.concatenate(bs), quads


def _shade(shape: FishShape, u: np.ndarray, b: np.ndarray) -> np.ndarray:
    """RGB (N, 3) of the body at (u, b): counter-shading from back to belly, the pattern, an eye."""
    h = np.maximum(shape.half_height(np.minimum(u, shape.peduncle)), 1e-6)
    s = np.clip((b / h + 1) / 2, 0, 1)[:, None]  # 0 belly … 1 back
    colour = np.asarray(shape.belly) * (1 - s) + np.asarray(shape.back) * s
    k = shape.pattern_scale
    if shape.pattern == "bars":
        mark = np.cos(2 * np.pi * u * k) > 0.3
    elif shape.pattern == "stripes":
        mark = np.cos(2 * np.pi * b / shape.depth * 2.5) > 0.5
    elif shape.pattern == "spots":
        mark = (np.cos(2 * np.pi * u * k * 1.5) * np.cos(2 * np.pi * b / shape.depth * 3) > 0.6)
    else:
        mark = np.zeros(len(u), bool)
    colour = colour * np.where(mark & (u < shape.peduncle), 1 - shape.pattern_strength, 1.0)[:, None]
    fins = (u > shape.peduncle) | (np.abs(b) > shape.half_height(np.minimum(u, shape.peduncle)) * 1.01)
    colour = np.where(fins[:, None], colour * 0.8 + 20, colour)
    eye_u = 0.05 + 0.1 * shape.depth
    eye = (u - eye_u) ** 2 + (b - 0.2 * shape.half_height(np.array(eye_u))) ** 2 < (0.18 * shape.depth * 0.35) ** 2
    return np.where(eye[:, None], 15.0, colour)


def _outline(occluder: Occluder, camera: Camera) -> np.ndarray:
    """The occluder's outline (M, 3) m: a wobbly ellipse facing the camera."""
    rng = np.random.default_rng(occluder.seed)
    angle = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    wobble = 1 + sum(rng.uniform(0, 0.18) * np.cos(k * angle + rng.uniform(0, 2 * np.pi)) for k in (2, 3, 5))
    x = occluder.radius * wobble * np.cos(angle) * occluder.elongation
    y = occluder.radius * wobble * np.sin(angle) / occluder.elongation
    c, s = np.cos(occluder.angle), np.sin(occluder.angle)
    m = camera.exterior.rotation
    right, up = m[:, 0], m[:, 1]
    return np.asarray(occluder.centre) + (c * x - s * y)[:, None] * right + (s * x + c * y)[:, None] * up


def _texture(rng: np.random.Generator, size: int = 256) -> np.ndarray:
    """Seabed texture (size × size, mean 0, deviation 1, periodic so that it tiles without seams): noise
    with a falling spectrum (mottling from pebbles to patches) and sand ripples."""
    k = np.fft.fftfreq(size)
    radius = np.hypot(k[:, None], k[None, :])
    spectrum = np.fft.fft2(rng.normal(0, 1, (size, size))) / np.maximum(radius, 1.0 / size) ** 1.4
    texture = np.real(np.fft.ifft2(spectrum)).astype(np.float32)
    y, x = np.mgrid[0:size, 0:size]
    waves = int(rng.integers(6, 30))
    texture /= max(float(texture.std()), 1e-6)
    texture += 0.5 * np.sin(2 * np.pi * waves * (x + int(rng.integers(0, 3)) * y) / size).astype(np.float32)
    return texture / max(float(texture.std()), 1e-6)


def _seabed(scene: FishScene, camera: Camera, width: int, height: int, rng: np.random.Generator
            ) -> tuple[np.ndarray, np.ndarray]:
    """The seabed's colour (H, W, 3) and path length (H, W, m; 1e3 where no ray meets it) at the drawing's
    resolution: ray-traced on a grid every 8 image pixels, interpolated to the frame, then enlarged."""
    big = (width * _SUPER, height * _SUPER)
    if scene.seabed is None:
        return np.zeros((big[1], big[0], 3), np.float32), np.full((big[1], big[0]), _FAR, np.float32)
    step = 8
    gx, gy = np.arange(-0.5, width + step, step), np.arange(-0.5, height + step, step)
    xs, ys = np.meshgrid(gx, gy)
    rays = camera.rays(np.column_stack([xs.ravel(), ys.ravel()]))
    point, normal = np.asarray(scene.seabed[0], float), np.asarray(scene.seabed[1], float)
    normal = normal / np.linalg.norm(normal)
    denominator = rays.directions @ normal
    safe = np.where(np.abs(denominator) > 1e-9, denominator, -1e-9)
    t = ((point - rays.origins) @ normal) / safe
    t = np.where((t > 0) & rays.ok & (np.abs(denominator) > 1e-9), t, np.inf)
    hit = rays.origins + np.where(np.isfinite(t), t, 0.0)[:, None] * rays.directions
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(normal, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    texture = _texture(rng)
    size = texture.shape[0]
    cell = rng.uniform(0.01, 0.03)  # m per texel
    # texel coordinates, wrapped once per grid node (remap then reads the periodic texture with BORDER_WRAP)
    tex_u = np.mod((hit - point) @ e1 / cell, size).reshape(xs.shape).astype(np.float32)
    tex_v = np.mod((hit - point) @ e2 / cell, size).reshape(xs.shape).astype(np.float32)
    far = np.isinf(t).reshape(xs.shape)
    path = np.where(far, _FAR, t.reshape(xs.shape)).astype(np.float32)
    # grid node (i, j) sits at image pixel (gx[j], gy[i]): interpolate the (unwrapped) coordinates per pixel
    unwrapped_u = np.unwrap(np.unwrap(tex_u, period=size, axis=1), period=size, axis=0)
    unwrapped_v = np.unwrap(np.unwrap(tex_v, period=size, axis=1), period=size, axis=0)
    map_x = np.ascontiguousarray(np.broadcast_to(((np.arange(width) - gx[0]) / step).astype(np.float32)[None, :],
                                                 (height, width)))
    map_y = np.ascontiguousarray(np.broadcast_to(((np.arange(height) - gy[0]) / step).astype(np.float32)[:, None],
                                                 (height, width)))
    u, v, path = (cv2.remap(a.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
                  for a in (unwrapped_u, unwrapped_v, path))
    value = cv2.remap(texture, np.mod(u, size), np.mod(v, size), cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    colour = np.asarray(scene.seabed_colour, np.float32)[None, None, :] * (1 + 0.25 * value[..., None])
    colour = np.where((path < _FAR * 0.99)[..., None], colour, 0).astype(np.float32)
    return (cv2.resize(colour, big, interpolation=cv2.INTER_LINEAR),
            cv2.resize(path, big, interpolation=cv2.INTER_LINEAR))


def render_fish_scene(camera: Camera, scene: FishScene, size: tuple[int, int] | None = None
                      ) -> tuple[np.ndarray, list[FishTruth]]:
    """The frame (H × W × 3 uint8, **BGR** as OpenCV reads images) of ``scene`` as ``camera`` sees it, and
    each fish's truth (same order as ``scene.fish``). Fish are drawn far to near, occluders by their
    distance among them; truth visibility comes from the drawn ownership of each pixel."""
    width, height = size if size else (camera.width, camera.height)
    if not width or not height:
        raise InvalidParameterError("size", "give the image size or a camera with width and height")
    rng = np.random.default_rng(scene.seed)
    canvas, path = _seabed(scene, camera, width, height, rng)
    owner = np.full(canvas.shape[:2], -1, np.int32)
    position = camera.exterior.position
    meshes = [_mesh(f.shape) for f in scene.fish]
    # one projection call for every node of every fish and occluder
    pieces, truths_points = [], []
    for fish, (u, b, _) in zip(scene.fish, meshes, strict=True):
        pieces.append(fish.place(u, b))
        truths_points.append(fish.keypoint_points())
    outlines = [_outline(o, camera) for o in scene.occluders]
    everything = np.concatenate(pieces + truths_points + outlines) if (pieces or outlines) else np.zeros((0, 3))
    projection = camera.project(everything) if len(everything) else None
    usable_all = np.zeros(len(everything), bool)
    if projection is not None:
        near_frame = np.all(np.abs(projection.pixels - np.array([width, height]) / 2) < 2 * max(width, height), axis=1)
        usable_all = ((projection.status == RayStatus.OK) | (projection.status == RayStatus.OUTSIDE_FRAME)) & near_frame
    offset = 0
    drawn = []  # (distance, kind, index, pixels, ok)
    for i, piece in enumerate(pieces):
        n = len(piece)
        drawn.append((float(np.linalg.norm(np.mean(piece, axis=0) - position)), "fish", i,
                      projection.pixels[offset:offset + n], usable_all[offset:offset + n]))
        offset += n
    keypoint_pixels = []
    for points in truths_points:
        keypoint_pixels.append((projection.pixels[offset:offset + len(points)],
                                projection.status[offset:offset + len(points)]))
        offset += len(points)
    for i, outline in enumerate(outlines):
        n = len(outline)
        drawn.append((float(np.linalg.norm(scene.occluders[i].centre - position)), "occluder", i,
                      projection.pixels[offset:offset + n], usable_all[offset:offset + n]))
        offset += n
    areas = np.zeros(len(scene.fish))
    for distance, kind, index, pixels, usable in sorted(drawn, key=lambda item: -item[0]):
        big = np.round(((pixels + 0.5) * _SUPER - 0.5) * 16).astype(np.int64)  # 4 bits of sub-pixel
        if kind == "occluder":
            occluder = scene.occluders[index]
            if not usable.all():
                continue
            polygon = big.astype(np.int32)
            cv2.fillPoly(canvas, [polygon], tuple(float(c) for c in occluder.colour), cv2.LINE_8, 4)
            mask = np.zeros(owner.shape, np.uint8)
            cv2.fillPoly(mask, [polygon], 1, cv2.LINE_8, 4)
            owner[mask > 0] = -2
            path[mask > 0] = distance
            continue
        fish = scene.fish[index]
        u, b, quads = meshes[index]
        quads = np.asarray(quads)
        centre_u, centre_b = u[quads].mean(axis=1), b[quads].mean(axis=1)
        colours = _shade(fish.shape, centre_u, centre_b)
        ok = usable[quads].all(axis=1)
        mask = np.zeros(owner.shape, np.uint8)
        polygons = big[quads].astype(np.int32)
        for q in np.flatnonzero(ok):
            cv2.fillConvexPoly(canvas, polygons[q], tuple(float(c) for c in colours[q]), cv2.LINE_8, 4)
            cv2.fillConvexPoly(mask, polygons[q], 1, cv2.LINE_8, 4)
        inside = mask > 0
        owner[inside] = index
        path[inside] = distance
        areas[index] = inside.sum()
    image = _water(canvas, path, scene, rng)
    truths = []
    small_owner = owner[_SUPER // 2::_SUPER, _SUPER // 2::_SUPER]
    for index, fish in enumerate(scene.fish):
        pixels, status = keypoint_pixels[index]
        mine = owner == index
        visible_fraction = float(mine.sum() / areas[index]) if areas[index] else 0.0
        ys, xs = np.nonzero(mine)
        if len(xs):
            box = ((xs.min() + 0.5) / _SUPER - 0.5 - 0.5 / _SUPER, (ys.min() + 0.5) / _SUPER - 0.5 - 0.5 / _SUPER,
                   (xs.max() + 0.5) / _SUPER - 0.5 + 0.5 / _SUPER, (ys.max() + 0.5) / _SUPER - 0.5 + 0.5 / _SUPER)
        else:
            box = (np.nan,) * 4
        visible = np.zeros(len(pixels), bool)
        for k, (x, y) in enumerate(pixels):
            if status[k] != RayStatus.OK or not (-0.5 <= x < width - 0.5 and -0.5 <= y < height - 0.5):
                continue
            xi, yi = int(np.clip(np.rint(x), 0, width - 1)), int(np.clip(np.rint(y), 0, height - 1))
            near = small_owner[max(0, yi - 1):yi + 2, max(0, xi - 1):xi + 2]
            visible[k] = bool((near == index).any())
        truths.append(FishTruth(pixels.copy(), visible, tuple(float(v) for v in box), visible_fraction,
                                fish.keypoint_points(), fish.shape.plan,
                                float(np.linalg.norm(fish.keypoint_points()[1] - fish.keypoint_points()[0]))))
    return image, truths


def _water(canvas: np.ndarray, path: np.ndarray, scene: FishScene, rng: np.random.Generator) -> np.ndarray:
    """Averaged down to the frame, then attenuation and backscatter over each pixel's path, particles,
    vignetting, colour cast, blur and noise; 8-bit BGR."""
    h, w = canvas.shape[0] // _SUPER, canvas.shape[1] // _SUPER
    image = cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA)
    path = cv2.resize(path, (w, h), interpolation=cv2.INTER_AREA)
    attenuation = np.asarray(scene.attenuation, np.float32)
    backscatter = np.asarray(scene.backscatter, np.float32)
    transmission = np.exp(-attenuation[None, None, :] * path[..., None])
    image = image * transmission + backscatter[None, None, :] * (1 - transmission)
    if scene.particles:
        xs = rng.integers(0, w, scene.particles)
        ys = rng.integers(0, h, scene.particles)
        glow = np.zeros((h, w), np.float32)
        glow[ys, xs] = rng.uniform(80, 250, scene.particles)
        glow = cv2.GaussianBlur(glow, (0, 0), 1.0) * 3
        image = image + glow[..., None] * (backscatter / max(float(backscatter.max()), 1.0) * 0.5 + 0.5)
    if scene.vignette:
        r2 = (((np.arange(w) - w / 2) / (w / 2)) ** 2)[None, :] + (((np.arange(h) - h / 2) / (h / 2)) ** 2)[:, None]
        image = image * (1 - scene.vignette * r2.astype(np.float32) / 2)[..., None]
    image = image * np.asarray(scene.cast, np.float32)[None, None, :]
    if scene.blur > 0:
        image = cv2.GaussianBlur(image, (0, 0), scene.blur)
    image = image + rng.normal(0, scene.noise, image.shape).astype(np.float32)
    return np.ascontiguousarray(np.clip(np.rint(image), 0, 255).astype(np.uint8)[:, :, ::-1])


def random_camera(rng: np.random.Generator, kind: str, size: tuple[int, int]) -> Camera:
    """A camera of housing ``kind`` (its default parameters) with a frame of ``size`` (width, height)
    pixels, a horizontal field of view of 50-90° (in air), mild lens distortion and a small random tilt,
    at the origin looking along −Z."""
    width, height = size
    f = width / 2 / np.tan(np.radians(rng.uniform(50, 90)) / 2)
    interior = Interior(float(f), width / 2 + rng.normal(0, 0.01 * width), height / 2 + rng.normal(0, 0.01 * height),
                        k1=float(rng.uniform(-0.04, 0.01)))
    exterior = Exterior(0.0, 0.0, 0.0, *rng.normal(0, 0.05, 3))
    return Camera(interior, exterior, housings.kind(kind).from_symbols(), width, height)


def random_scene(rng: np.random.Generator, camera: Camera, fish: tuple[int, int] = (1, 6),
                 ranges: tuple[float, float] = (0.8, 3.5), lengths: tuple[float, float] = (0.12, 0.7),
                 occluders: tuple[int, int] = (0, 3)) -> FishScene:
    """A random scene in front of ``camera`` (its frame size must be set): ``fish`` (fewest, most) fish at
    ``ranges`` (m) from it with fork ``lengths`` (m), mostly side-on, ``occluders`` weed and rocks, a seabed
    (or open water) and random water. Fish sizes are chosen so most lie wholly in the frame."""
    if not camera.width or not camera.height:
        raise InvalidParameterError("camera", "give the camera a frame width and height")
    m = camera.exterior.rotation
    right, up, forward = m[:, 0], m[:, 1], -m[:, 2]
    position = camera.exterior.position
    tan_x = camera.width / 2 / camera.interior.f
    tan_y = camera.height / 2 / camera.interior.f
    items = []
    for _ in range(int(rng.integers(fish[0], fish[1] + 1))):
        distance = rng.uniform(*ranges)
        length = min(rng.uniform(*lengths), 0.8 * distance * tan_x)
        x = rng.uniform(-1, 1) * max(distance * tan_x - 0.4 * length, 0.0)
        y = rng.uniform(-1, 1) * max(distance * tan_y - 0.2 * length, 0.0)
        centre = position + distance * forward + x * right + y * up
        yaw = rng.choice([0.0, np.pi]) + rng.normal(0, 0.45)  # mostly side-on, either way
        pitch = rng.normal(0, 0.2)
        heading = np.cos(pitch) * (np.cos(yaw) * right + np.sin(yaw) * forward) + np.sin(pitch) * up
        roll = rng.normal(0, 0.15)
        dorsal = up - (up @ heading) * heading
        dorsal /= np.linalg.norm(dorsal)
        side = np.cross(heading, dorsal)
        dorsal = np.cos(roll) * dorsal + np.sin(roll) * side
        snout = centre - 0.5 * length * heading
        items.append(SceneFish(random_shape(rng), tuple(snout), tuple(heading), tuple(dorsal), float(length),
                               float(rng.normal(0, 0.15))))
    blobs = []
    for _ in range(int(rng.integers(occluders[0], occluders[1] + 1))):
        distance = rng.uniform(0.5, ranges[1])
        x = rng.uniform(-1, 1) * distance * tan_x
        y = rng.uniform(-1, 1) * distance * tan_y
        centre = position + distance * forward + x * right + y * up
        weed = rng.uniform() < 0.5
        colour = (rng.uniform(30, 80), rng.uniform(70, 140), rng.uniform(20, 60)) if weed else tuple(
            rng.uniform(50, 140) * np.array([1.0, 0.95, 0.85]))
        blobs.append(Occluder(tuple(centre), float(rng.uniform(0.04, 0.12) * distance), colour,
                              float(rng.uniform(2.0, 4.0) if weed else rng.uniform(1.0, 1.6)),
                              float(rng.uniform(0, np.pi)), int(rng.integers(1 << 30))))
    seabed = None
    if rng.uniform() < 0.85:
        tilt = rng.uniform(0.1, 1.3)  # 0: a floor seen edge-on below, ~1.3: looking down on it
        normal = np.cos(tilt) * up - np.sin(tilt) * forward
        below = ranges[1] * 1.3
        point = position + below * forward - rng.uniform(0.6, 1.2) * tan_y * below * up * np.cos(tilt)
        seabed = (tuple(point), tuple(normal))
    turbidity = rng.uniform(0.04, 0.35)
    ratio = np.array([rng.uniform(1.5, 3.0), 1.0, rng.uniform(0.6, 1.1)])  # red absorbed most
    water_tone = np.array([rng.uniform(10, 60), rng.uniform(60, 150), rng.uniform(60, 160)])
    sand = np.array([rng.uniform(120, 210), rng.uniform(110, 190), rng.uniform(80, 160)])
    return FishScene(tuple(items), tuple(blobs), seabed, tuple(sand), tuple(turbidity * ratio), tuple(water_tone),
                     float(rng.uniform(0.0, 1.5)), float(rng.uniform(1.0, 5.0)), int(rng.integers(0, 400)),
                     tuple(rng.uniform(0.8, 1.2, 3)), float(rng.uniform(0, 0.6)), int(rng.integers(1 << 30)))
