"""Rendered pointing targets whose true image points are known: for a person's pointing test (click N of
them; :func:`usvips.core.pointing_estimates.from_pointing_test` gives the σ) and for the pointing
experiment that measures how well defined each kind of point is (``usvips bench``'s pointing rows,
docs/pointing.md).

A trial is one small image rendered by the project's ray tracer (:func:`usvips.core.synth.render`) through
a camera 1-1.4 m from the feature, in water of one of :data:`CONDITIONS` (blur, attenuation, backscatter,
sensor noise), showing one :data:`FEATURES`: the centre of a calibration target's cross, a fish's snout
tip, or the deepest point of its tail fork. Its truth is the feature's 3-D point projected by the same
camera (pixels, centre of the top-left pixel at (0, 0)). Deterministic for a seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.housing.kinds.air import AirHousing
from usvips.core.interior import Interior
from usvips.core.synth import Disc, Water, render
from usvips.core.synth.objects import Fish

#: what a trial shows (the point to click)
FEATURES = ("target centre", "fish snout", "fish fork")

#: the image side (px) of a trial
WIDTH, HEIGHT = 160, 120
#: the rendering camera's principal distance (px)
FOCAL_PX = 520.0


@dataclass(frozen=True)
class Condition:
    """How clear the water is: the image's Gaussian ``blur_px`` (σ, px), the ``attenuation`` (1/m) and
    ``backscatter`` (grey level) of the water, and the sensor ``noise`` (σ, grey levels)."""

    name: str
    blur_px: float
    attenuation: float
    backscatter: float
    noise: float

    @property
    def water(self) -> Water:
        return Water(self.attenuation, self.backscatter, self.blur_px, self.noise)


#: the conditions a test cycles through, clearest first
CONDITIONS = (Condition("clear", 0.6, 0.05, 40.0, 1.5), Condition("hazy", 1.3, 0.35, 70.0, 2.5),
              Condition("turbid", 2.2, 0.8, 90.0, 3.5))


@dataclass(frozen=True)
class Trial:
    """One rendered target: the ``feature`` (one of :data:`FEATURES`) to click, the ``condition``'s name,
    the grey ``image`` (HEIGHT, WIDTH) uint8 and the ``truth`` (x, y) px of the feature."""

    feature: str
    condition: str
    image: np.ndarray
    truth: tuple[float, float]

    @property
    def instruction(self) -> str:
        what = {"target centre": "the centre of the target's cross", "fish snout": "the tip of the fish's snout",
                "fish fork": "the deepest point of the fish's tail fork"}[self.feature]
        return f"Click {what} ({self.condition} water)"


def _camera() -> Camera:
    """A pinhole camera at the origin looking along −Z (the image's x to +X, y to −Y)."""
    return Camera(Interior(FOCAL_PX, (WIDTH - 1) / 2, (HEIGHT - 1) / 2, 1.0), Exterior(0.0, 0.0, 0.0), AirHousing(),
                  WIDTH, HEIGHT)


def _condition(name: str | Condition) -> Condition:
    if isinstance(name, Condition):
        return name
    for c in CONDITIONS:
        if c.name == name:
            return c
    known = ", ".join(c.name for c in CONDITIONS)
    raise InvalidParameterError("condition", f"unknown condition {name!r}; known: {known}")


def scene(feature: str, rng: np.random.Generator) -> tuple[dict, np.ndarray, np.ndarray | None]:
    """A random scene showing ``feature`` near the image's centre: the renderer's keyword arguments (discs,
    objects), the feature's 3-D point (m) and, on a fish, the other end of its snout–fork axis (m; None on
    a target)."""
    if feature not in FEATURES:
        raise InvalidParameterError("feature", f"unknown feature {feature!r}; known: {', '.join(FEATURES)}")
    distance = rng.uniform(1.0, 1.4)
    # the feature a few pixels off the centre, so that the centre of the image is no hint
    offset = rng.uniform(-14, 14, 2) / FOCAL_PX * distance
    point = np.array([offset[0], -offset[1], -distance])
    if feature == "target centre":
        tilt = rng.uniform(-0.25, 0.25, 2)
        normal = np.array([tilt[0], tilt[1], 1.0])
        return {"discs": [Disc(tuple(point), tuple(normal / np.linalg.norm(normal)), radius=0.035,
                               cross_width=0.005)]}, point, None
    angle = rng.uniform(0, 2 * np.pi)
    axis = np.array([np.cos(angle), np.sin(angle), rng.uniform(-0.2, 0.2)])
    axis /= np.linalg.norm(axis)
    length = rng.uniform(0.16, 0.24)
    up = np.cross(axis, [0.0, 0.0, 1.0])
    if feature == "fish snout":
        snout, fork = point, point + length * axis
    else:
        snout, fork = point - length * axis, point
    fish = Fish(tuple(snout), tuple(fork), up=tuple(up), brightness=rng.uniform(140, 200))
    return {"objects": [fish]}, point, fork if feature == "fish snout" else snout


def render_trial(feature: str, condition: str | Condition, seed: int, noise_seed: int | None = None,
                 supersample: int = 3) -> Trial:
    """The trial of ``feature`` in ``condition`` drawn by ``seed`` (the scene) and ``noise_seed`` (the
    sensor noise; default ``seed``)."""
    condition = _condition(condition)
    arguments, point, _ = scene(feature, np.random.default_rng(seed))
    camera = _camera()
    image = render(camera, water=condition.water, supersample=supersample, background=55.0,
                   seed=seed if noise_seed is None else noise_seed, **arguments)
    truth = camera.project_point(point)
    return Trial(feature, condition.name, image, (float(truth[0]), float(truth[1])))


def plan(count: int, seed: int = 0) -> list[tuple[str, str, int]]:
    """``count`` trials' (feature, condition, seed): every feature in every condition in turn, shuffled."""
    if not 1 <= int(count) <= 200:
        raise InvalidParameterError("count", f"must be 1 to 200 targets, got {count}")
    rng = np.random.default_rng(seed)
    cells = [(f, c.name) for f in FEATURES for c in CONDITIONS]
    order = [cells[i % len(cells)] for i in range(int(count))]
    rng.shuffle(order)
    return [(f, c, int(s)) for (f, c), s in zip(order, rng.integers(0, 2**31, len(order)), strict=True)]


# ------------------------------------------------------------------------------------------ the experiment
#: the side (px) of the neighbourhood a person judges a point by (the experiment's window)
WINDOW = 15


def how_well_defined(feature: str, condition: str | Condition, seed: int, draws: int = 20) -> dict:
    """How well the image defines ``feature`` in ``condition`` (one scene drawn by ``seed``), in pixels:

    - ``crlb_px``: the Cramér–Rao bound of locating the feature's :data:`WINDOW` × WINDOW neighbourhood
      under the sensor noise (σ² = σ_n² · [F⁻¹], F = Σ ∇I ∇Iᵀ over the window of the noise-free image, per
      coordinate, the mean of x and y): no observer, human or program, locates it better on average;
    - ``located_px``: the spread (per coordinate) of the least-squares shift of the noisy window against the
      noise-free one over ``draws`` noise draws: the bound reached by the best program;
    - ``edge_offset_px``: on a fish, where the visible edge is along the snout–fork axis (half way between
      the body's and the water's grey, outward positive) relative to the true point — the point's definition
      under blur and haze (a person clicking the visible tip is off by this); NaN on a target.
    """
    from scipy.ndimage import map_coordinates

    condition = _condition(condition)
    arguments, point, inward = scene(feature, np.random.default_rng(seed))
    camera = _camera()
    quiet = Condition(condition.name, condition.blur_px, condition.attenuation, condition.backscatter, 1e-9)
    clean = render(camera, water=quiet.water, supersample=2, background=55.0, seed=seed, **arguments)
    clean = clean.astype(np.float64)
    truth = camera.project_point(point)
    half = WINDOW // 2
    x0, y0 = int(round(truth[0])), int(round(truth[1]))
    gy, gx = np.gradient(clean)
    window = (slice(y0 - half, y0 + half + 1), slice(x0 - half, x0 + half + 1))
    fisher = np.array([[np.sum(gx[window] ** 2), np.sum(gx[window] * gy[window])],
                       [np.sum(gx[window] * gy[window]), np.sum(gy[window] ** 2)]])
    noise = np.hypot(condition.noise, 1 / np.sqrt(12))  # the sensor's, and the 8-bit rounding's
    crlb = float(np.sqrt(noise ** 2 * np.trace(np.linalg.inv(fisher)) / 2))
    rng = np.random.default_rng(seed + 1)
    shifts = []
    gradient = np.stack([gx[window].ravel(), gy[window].ravel()])
    for _ in range(draws):
        noisy = np.clip(np.rint(clean + rng.normal(0, condition.noise, clean.shape)), 0, 255)
        # the least-squares shift of the noisy window against the noise-free one (a Gauss–Newton step of
        # Lucas–Kanade from the truth: the estimator the bound is the variance of)
        shifts.append(-np.linalg.solve(fisher, gradient @ (noisy[window] - clean[window]).ravel()))
    located = float(np.sqrt(np.mean(np.var(np.array(shifts), axis=0, ddof=1))))
    offset = float("nan")
    if inward is not None:
        inward = point + 0.02 * (inward - point) / np.linalg.norm(inward - point)  # 2 cm into the body
        into = camera.project_point(inward) - truth
        into /= np.linalg.norm(into)  # image direction from the point into the body
        t = np.arange(-8.0, 8.0, 0.05)  # px along the axis, outward positive
        samples = truth[None, :] - t[:, None] * into[None, :]
        profile = map_coordinates(clean, [samples[:, 1], samples[:, 0]], order=1)
        # the body's grey: its bright part (the eye, dark, lies a few px behind the snout), the water's beyond
        body, water = np.percentile(profile[t < -2], 90), profile[t > 5].mean()
        level = (body + water) / 2
        crossing = np.flatnonzero(np.diff(np.sign(profile - level)) != 0)
        if crossing.size:
            k = crossing[np.argmin(np.abs(t[crossing]))]
            offset = float(t[k] + (level - profile[k]) / (profile[k + 1] - profile[k]) * (t[k + 1] - t[k]))
    return {"feature": feature, "condition": condition.name, "crlb_px": crlb, "located_px": located,
            "edge_offset_px": offset}
