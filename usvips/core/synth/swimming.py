"""A fish that swims and bends, with its truth at every instant: for tracking and several-instant tests.

The body is laterally flat: a vertical sheet standing on the fish's midline, a curve of fork length
``length`` (m) in the horizontal plane spanned by ``heading`` and ``side`` = ``up`` × ``heading``. The
midline bends as a carangiform travelling wave: its tangent turns by

    θ(s, t) = bend · (s / L)² · sin(2π (s / λ − f t)),   s ∈ [0, L] from the snout,

(``bend`` radians at the fork, wavelength λ = ``wavelength`` × L, tail-beat frequency f = ``beat_hz``),
integrated along s so the body keeps its length exactly (the chord snout → fork shortens as it bends).
The snout moves along ``heading`` at ``speed`` (m/s) from ``start``. A body point is named by (s, v):
s (m) along the midline from the snout, v (m) along ``up`` from the midline. Its surface is textured in
body coordinates (the texture moves with the fish: points on it can be tracked), with an eye near the
snout. ``at(t)`` gives an object for :func:`usvips.core.synth.render.render` at time t (s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core import validation

#: samples along the midline (the polyline the sheet stands on)
SAMPLES = 81


@dataclass(frozen=True)
class SwimmingFish:
    """A swimming, bending fish (see the module docstring). Metres, seconds, radians."""

    start: tuple[float, float, float]
    heading: tuple[float, float, float] = (1.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    length: float = 0.3
    speed: float = 0.3
    bend: float = 0.6
    wavelength: float = 1.0
    beat_hz: float = 2.0
    phase: float = 0.0
    depth_ratio: float = 0.28
    brightness: float = 150.0
    seed: int = 0
    colour: tuple[float, float, float] = (0.8, 0.9, 1.0)

    def __post_init__(self) -> None:
        validation.finite_vector("start", self.start, 3)
        heading = validation.finite_vector("heading", self.heading, 3)
        up = validation.finite_vector("up", self.up, 3)
        validation.positive("length", self.length)
        validation.positive("wavelength", self.wavelength)
        if np.linalg.norm(heading) == 0 or np.linalg.norm(up) == 0:
            raise validation.InvalidParameterError("heading", "heading and up must not be zero vectors")
        if np.linalg.norm(np.cross(heading, up)) < 0.1 * np.linalg.norm(heading) * np.linalg.norm(up):
            raise validation.InvalidParameterError("up", "must not be parallel to the heading")

    def _axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        heading = np.asarray(self.heading, float)
        heading = heading / np.linalg.norm(heading)
        up = np.asarray(self.up, float)
        up = up - (up @ heading) * heading
        up /= np.linalg.norm(up)
        return heading, up, np.cross(up, heading)

    def midline(self, t: float, s: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Points (M, 3) m of the midline at time ``t`` (s) at arc lengths ``s`` (M,) m (default
        :data:`SAMPLES` evenly from snout to fork), and the arc lengths."""
        grid = np.linspace(0.0, self.length, SAMPLES * 4 + 1)
        angle = self.bend * (grid / self.length) ** 2 * np.sin(
            2 * np.pi * (grid / (self.wavelength * self.length) - self.beat_hz * t) + self.phase)
        steps = np.diff(grid)
        middle = 0.5 * (angle[1:] + angle[:-1])
        along = np.concatenate([[0.0], np.cumsum(np.cos(middle) * steps)])
        across = np.concatenate([[0.0], np.cumsum(np.sin(middle) * steps)])
        s = np.linspace(0.0, self.length, SAMPLES) if s is None else np.asarray(s, float)
        a, c = np.interp(s, grid, along), np.interp(s, grid, across)
        heading, up, side = self._axes()
        snout = np.asarray(self.start, float) + self.speed * float(t) * heading
        return snout + a[:, None] * heading + c[:, None] * side, s

    def body_point(self, t: float, s: float, v: float = 0.0) -> np.ndarray:
        """The 3-D position (m) at time ``t`` of the body point ``s`` m from the snout, ``v`` m up."""
        point, _ = self.midline(t, np.array([float(s)]))
        return point[0] + float(v) * self._axes()[1]

    def snout_fork(self, t: float) -> np.ndarray:
        """(2, 3): the snout and the fork at time ``t`` (their distance is the chord, ≤ ``length``)."""
        return self.midline(t, np.array([0.0, self.length]))[0]

    def half_depth(self, s: np.ndarray) -> np.ndarray:
        """Half the body's depth (m) at ``s`` (m from the snout): round head, deepest at a third, a
        narrow peduncle and a forked tail."""
        u = np.clip(np.asarray(s, float) / self.length, 0.0, 1.0)
        body = 0.5 * self.depth_ratio * self.length * np.sqrt(u) * (1 - u) / (np.sqrt(1 / 3) * 2 / 3)
        tail = 0.5 * self.depth_ratio * self.length * np.clip((u - 0.85) * 4.0, 0.0, None)
        return np.maximum(body, tail) + 0.01 * self.length * (u > 0.0)

    def texture(self, s: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Grey value (0-255) of the body at (s, v): smooth random blobs in body coordinates, an eye."""
        rng = np.random.default_rng(self.seed)
        centres = rng.uniform(0, 1, (40, 2))
        weights = rng.uniform(-1, 1, 40)
        width = 0.045
        u = np.asarray(s, float)[..., None] / self.length
        w = 0.5 + np.asarray(v, float)[..., None] / (self.depth_ratio * self.length)
        blobs = (weights * np.exp(-((u - centres[:, 0]) ** 2 + (w - centres[:, 1]) ** 2) / (2 * width ** 2))).sum(-1)
        value = self.brightness * (1.0 + 0.45 * np.tanh(blobs)) - 25.0 * (w[..., 0] - 0.5)
        eye = (u[..., 0] - 0.08) ** 2 + ((w[..., 0] - 0.6) * self.depth_ratio) ** 2 < 0.025 ** 2
        return np.where(eye, 25.0, value)

    def at(self, t: float) -> FishAtInstant:
        """The fish at time ``t`` (s), as an object the renderer draws."""
        return FishAtInstant(self, float(t))


@dataclass(frozen=True)
class FishAtInstant:
    """A :class:`SwimmingFish` frozen at ``t`` (s): ``hit(origins, directions)`` for the renderer."""

    fish: SwimmingFish
    t: float

    @property
    def colour(self) -> tuple[float, float, float]:
        return self.fish.colour

    def hit(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ray parameter (m, inf where missed) and grey value of N rays against the body sheet."""
        fish = self.fish
        heading, up, side = fish._axes()
        points, s = fish.midline(self.t)
        n = len(origins)
        best_t = np.full(n, np.inf)
        values = np.zeros(n)
        # the sheet is vertical (along up) over the midline: intersect in the horizontal plane
        o2 = np.column_stack([origins @ heading, origins @ side])
        d2 = np.column_stack([directions @ heading, directions @ side])
        p2 = np.column_stack([points @ heading, points @ side])
        reach = fish.length * (1 + fish.depth_ratio)
        centre = p2.mean(axis=0)
        # rays whose horizontal line passes near the fish (cheap cull)
        normal = np.column_stack([-d2[:, 1], d2[:, 0]])
        norm = np.linalg.norm(normal, axis=1)
        near = (norm > 1e-12) & (np.abs(np.einsum("ij,ij->i", centre - o2, normal)) <= reach * norm)
        index = np.flatnonzero(near)
        if index.size == 0:
            return best_t, values
        o2n, d2n, on, dn = o2[index], d2[index], origins[index], directions[index]
        a, b = p2[:-1], p2[1:]
        e = b - a                                           # (M-1, 2)
        # solve o + t d = a + r e for (t, r) per ray and segment
        det = d2n[:, None, 0] * (-e[None, :, 1]) - d2n[:, None, 1] * (-e[None, :, 0])
        rel = a[None, :, :] - o2n[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (rel[..., 0] * (-e[None, :, 1]) - rel[..., 1] * (-e[None, :, 0])) / det
            r = (d2n[:, None, 0] * rel[..., 1] - d2n[:, None, 1] * rel[..., 0]) / det
        ok = np.isfinite(t) & (t > 0) & (r >= 0) & (r <= 1)
        along = s[:-1][None, :] + r * np.diff(s)[None, :]
        hit_points = on[:, None, :] + np.where(ok, t, 0.0)[..., None] * dn[:, None, :]
        height = hit_points @ up - (points[:-1] @ up)[None, :]
        ok &= np.abs(height) <= fish.half_depth(along)
        t = np.where(ok, t, np.inf)
        best = np.argmin(t, axis=1)
        rows = np.arange(len(index))
        found = np.isfinite(t[rows, best])
        best_t[index[found]] = t[rows, best][found]
        values[index[found]] = fish.texture(along[rows, best][found], height[rows, best][found])
        return best_t, values
