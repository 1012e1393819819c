"""A fish that swims and bends, with its truth at every instant: for tracking and several-instant tests.

The body is laterally flat: a vertical sheet standing on the fish's midline, a curve of fork length
``length`` (m) in the horizontal plane spanned by ``heading`` and ``side`` = ``up`` × ``heading``. The
midline bends as a carangiform travelling wave: its tangent turns by

    θ(s, t) = bend · (s / L)² · sin(2π (s / λ − f t)),   s ∈ [0, L] from the snout,

(``bend`` radians at the fork, wavelength λ = ``wavelength`` × L, tail-beat frequency f = ``beat_hz``),
integrated along s so the body keeps its length exactly (the chord snout → fork shortens as it bends).
The snout moves along ``heading`` at ``speed`` (m/s) from ``start``; the body trails behind it. A body
point is named by (s, v): s (m) along the midline from the snout, v (m) along ``up`` from the midline.
Its surface is textured in body coordinates (the texture moves with the fish: points on it can be
tracked), with an eye near the snout. ``at(t)`` gives an object for
:func:`usvips.core.synth.render.render` at time t (s).
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
        return snout - a[:, None] * heading + c[:, None] * side, s

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
        centres = rng.uniform(0, 1, (150, 2))
        weights = rng.uniform(-1, 1, 150)
        width = 0.035
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
        """Ray parameter (m, inf where missed) and grey value of N rays (unit ``directions``) against the
        body sheet. The midline is a function across(along) while its tangent turns by less than 90°
        (``bend`` < π/2), so each ray meets the sheet where o_c + t d_c = across(o_a + t d_a): solved by
        Newton's method from the plane through the snout, all rays at once."""
        fish = self.fish
        heading, up, side = fish._axes()
        points, s = fish.midline(self.t, np.linspace(0.0, fish.length, SAMPLES * 4 + 1))
        n = len(origins)
        best_t = np.full(n, np.inf)
        values = np.zeros(n)
        along, across = points[::-1] @ heading, points[::-1] @ side   # increasing along the heading
        s = s[::-1]
        if np.any(np.diff(along) <= 0):
            raise validation.InvalidParameterError("bend", f"{fish.bend:g} rad turns the body back on itself")
        slope = np.gradient(across, along)
        # only the rays passing within the fish's bounding sphere
        centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
        radius = 0.5 * np.linalg.norm(points.max(axis=0) - points.min(axis=0)) + float(fish.half_depth(s).max())
        to_centre = centre - origins
        gap = np.einsum("ij,ij->i", to_centre, to_centre) - np.einsum("ij,ij->i", to_centre, directions) ** 2
        near = np.flatnonzero(gap <= radius ** 2 * 1.0001)
        origins, directions = origins[near], directions[near]
        o_a, o_c, d_a, d_c = origins @ heading, origins @ side, directions @ heading, directions @ side
        facing = np.abs(d_c) > 1e-9
        t = np.where(facing, (across[0] - o_c) / np.where(facing, d_c, 1.0), np.inf)
        for _ in range(8):
            a = o_a + np.where(facing, t, 0.0) * d_a
            f = o_c + t * d_c - np.interp(a, along, across)
            derivative = d_c - np.interp(a, along, slope) * d_a
            t = np.where(facing & (np.abs(derivative) > 1e-12), t - f / np.where(np.abs(derivative) > 1e-12,
                                                                                derivative, 1.0), np.inf)
        a = o_a + np.where(np.isfinite(t), t, 0.0) * d_a
        at = np.interp(a, along, s)
        height = (origins + np.where(np.isfinite(t), t, 0.0)[:, None] * directions) @ up - points[0] @ up
        residual = np.abs(o_c + np.where(np.isfinite(t), t, 0.0) * d_c - np.interp(a, along, across))
        hit = (np.isfinite(t) & (t > 0) & (a >= along[0]) & (a <= along[-1]) & (residual < 1e-7)
               & (np.abs(height) <= fish.half_depth(at)))
        best_t[near[hit]] = t[hit]
        values[near[hit]] = fish.texture(at[hit], height[hit])
        return best_t, values
