"""Objects to measure in rendered scenes, each with exactly known geometry: a fish seen side-on (snout and
fork are the points a fish survey measures), a pipe segment with painted rings, and a rock.

Every object answers ``hit(origins, directions)`` for N rays (object space, metres, unit directions):
the ray parameter t (m, ``inf`` where the ray misses) and the grey value (0-255) where it hits. A
``colour`` tint (red, green, blue multipliers) is applied by the renderer in colour mode.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from usvips.core import validation

# Fish outline as fractions of the fork length along the body (u = 0 at the snout, 1 at the fork).
_PEDUNCLE_U = 0.86
_TAIL_END_U = 1.2
_BODY_PEAK = np.sqrt(1 / 3) * (2 / 3)  # max of sqrt(u)(1 - u), reached at u = 1/3


def _unit(name: str, vector: tuple[float, float, float]) -> np.ndarray:
    v = validation.finite_vector(name, vector, 3)
    norm = np.linalg.norm(v)
    if norm == 0:
        raise validation.InvalidParameterError(name, "must not be the zero vector")
    return v / norm


@dataclass(frozen=True)
class Fish:
    """A laterally flat fish in the plane spanned by snout → fork and ``up`` (its dorsal direction).

    ``snout`` and ``fork`` (m) are the survey's measuring points: the tip of the snout and the deepest
    point of the tail fork, so the true fork length is ``|fork − snout|``. ``depth`` is the greatest body
    depth (m). The body has darker back, lighter belly, vertical bars and an eye, to give matching texture.
    """

    snout: tuple[float, float, float]
    fork: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    depth: float = 0.0
    brightness: float = 170.0
    colour: tuple[float, float, float] = (0.8, 0.9, 1.0)

    def __post_init__(self) -> None:
        snout = validation.finite_vector("fish snout", self.snout, 3)
        fork = validation.finite_vector("fish fork", self.fork, 3)
        if np.linalg.norm(fork - snout) <= 0:
            raise validation.InvalidParameterError("fish fork", "must differ from the snout")
        axis = (fork - snout) / np.linalg.norm(fork - snout)
        up = _unit("fish up", self.up)
        if np.linalg.norm(np.cross(axis, up)) < 0.1:
            raise validation.InvalidParameterError("fish up", "must not be parallel to the snout-fork axis")
        if self.depth < 0:
            raise validation.InvalidParameterError("fish depth", "must be positive (metres)")

    @property
    def length(self) -> float:
        """Fork length (m)."""
        return float(np.linalg.norm(np.subtract(self.fork, self.snout)))

    def _frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        snout = np.asarray(self.snout, float)
        axis = (np.asarray(self.fork, float) - snout) / self.length
        up = np.asarray(self.up, float)
        up = up - (up @ axis) * axis
        up /= np.linalg.norm(up)
        depth = self.depth if self.depth > 0 else 0.28 * self.length
        return axis, up, np.cross(axis, up), depth

    def hit(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        axis, up, side, depth = self._frame()
        snout = np.asarray(self.snout, float)
        t = _plane_hit(origins, directions, snout, side)
        finite = np.isfinite(t)
        rel = origins[finite] + t[finite, None] * directions[finite] - snout
        u = rel @ axis / self.length
        b = rel @ up / depth  # in body depths, dorsal positive
        body_u = np.clip(u, 0.0, _PEDUNCLE_U)
        half = 0.5 * np.sqrt(body_u) * (1 - body_u) / _BODY_PEAK
        peduncle = 0.5 * np.sqrt(_PEDUNCLE_U) * (1 - _PEDUNCLE_U) / _BODY_PEAK
        in_body = (u >= 0) & (u <= _PEDUNCLE_U) & (np.abs(b) <= half)
        tail_half = peduncle + (u - _PEDUNCLE_U) * 1.4
        notch = (u - 1.0) * 2.0
        in_tail = (u > _PEDUNCLE_U) & (u <= _TAIL_END_U) & (np.abs(b) <= tail_half) & ~((u > 1.0) & (np.abs(b) < notch))
        inside = in_body | in_tail
        shade = 1.0 - 0.35 * (b + 0.5) + 0.12 * np.cos(2 * np.pi * u * 7)
        eye = (u - 0.07) ** 2 + ((b - 0.1) * depth / self.length) ** 2 < 0.018**2
        value = np.where(eye, 20.0, self.brightness * shade)
        hit_t = np.full(len(origins), np.inf)
        values = np.zeros(len(origins))
        index = np.flatnonzero(finite)[inside]
        hit_t[index] = t[finite][inside]
        values[index] = value[inside]
        return hit_t, values

    def translated(self, offset) -> Fish:
        """The same fish moved by ``offset`` (m): a frame of a fish swimming."""
        d = validation.finite_vector("offset", offset, 3)
        return replace(self, snout=tuple(np.add(self.snout, d)), fork=tuple(np.add(self.fork, d)))

    def points(self) -> dict[str, list[float]]:
        return {"snout": list(map(float, self.snout)), "fork": list(map(float, self.fork))}


@dataclass(frozen=True)
class Pipe:
    """A cylinder of ``radius`` (m) whose axis runs from ``start`` to ``end`` (m), with dark painted rings
    of ``ring_width`` every ``ring_spacing`` metres along it (lit from the camera, a head lamp)."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float = 0.05
    ring_spacing: float = 0.1
    ring_width: float = 0.01
    brightness: float = 190.0
    colour: tuple[float, float, float] = (1.0, 0.75, 0.35)

    def __post_init__(self) -> None:
        start = validation.finite_vector("pipe start", self.start, 3)
        end = validation.finite_vector("pipe end", self.end, 3)
        if np.linalg.norm(end - start) <= 0:
            raise validation.InvalidParameterError("pipe end", "must differ from the start")
        validation.positive("pipe radius", self.radius)

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.subtract(self.end, self.start)))

    def hit(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        start = np.asarray(self.start, float)
        axis = (np.asarray(self.end, float) - start) / self.length
        rel = origins - start
        d_perp = directions - (directions @ axis)[:, None] * axis
        o_perp = rel - (rel @ axis)[:, None] * axis
        a = np.einsum("ij,ij->i", d_perp, d_perp)
        b = 2 * np.einsum("ij,ij->i", d_perp, o_perp)
        c = np.einsum("ij,ij->i", o_perp, o_perp) - self.radius**2
        disc = b * b - 4 * a * c
        valid = (disc >= 0) & (a > 1e-15)
        root = np.sqrt(np.where(valid, disc, 0.0))
        safe_a = np.where(valid, a, 1.0)
        t = np.where(valid, (-b - root) / (2 * safe_a), np.inf)
        s = (rel + np.where(np.isfinite(t), t, 0.0)[:, None] * directions) @ axis
        keep = valid & (t > 0) & (s >= 0) & (s <= self.length)
        t = np.where(keep, t, np.inf)
        normal = (o_perp + np.where(keep, t, 0.0)[:, None] * d_perp) / self.radius
        lit = np.clip(-np.einsum("ij,ij->i", normal, directions), 0.0, 1.0)
        ring = np.mod(s, self.ring_spacing) < self.ring_width
        values = np.where(keep, self.brightness * (0.3 + 0.7 * lit) * np.where(ring, 0.25, 1.0), 0.0)
        return t, values

    def translated(self, offset) -> Pipe:
        d = validation.finite_vector("offset", offset, 3)
        return replace(self, start=tuple(np.add(self.start, d)), end=tuple(np.add(self.end, d)))

    def points(self) -> dict[str, list[float]]:
        return {"start": list(map(float, self.start)), "end": list(map(float, self.end))}


@dataclass(frozen=True)
class Rock:
    """An ellipsoid rock: ``centre`` (m), semi-axes along X, Y, Z (m), a mottled surface lit by a head lamp."""

    centre: tuple[float, float, float]
    semi_axes: tuple[float, float, float] = (0.12, 0.09, 0.06)
    brightness: float = 140.0
    seed: int = 0
    colour: tuple[float, float, float] = (0.9, 0.85, 0.75)

    def __post_init__(self) -> None:
        validation.finite_vector("rock centre", self.centre, 3)
        axes = validation.finite_vector("rock semi_axes", self.semi_axes, 3)
        if np.any(axes <= 0):
            raise validation.InvalidParameterError("rock semi_axes", "must all be positive (metres)")

    def hit(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        axes = np.asarray(self.semi_axes, float)
        o = (origins - np.asarray(self.centre, float)) / axes
        d = directions / axes
        a = np.einsum("ij,ij->i", d, d)
        b = 2 * np.einsum("ij,ij->i", o, d)
        c = np.einsum("ij,ij->i", o, o) - 1
        disc = b * b - 4 * a * c
        valid = disc >= 0
        t = np.where(valid, (-b - np.sqrt(np.where(valid, disc, 0.0))) / (2 * a), np.inf)
        t = np.where(t > 0, t, np.inf)
        hit = np.isfinite(t)
        unit = o + np.where(hit, t, 0.0)[:, None] * d
        normal = unit / axes
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        lit = np.clip(-np.einsum("ij,ij->i", normal, directions), 0.0, 1.0)
        rng = np.random.default_rng(self.seed)
        waves = rng.normal(size=(6, 3)) * 9.0
        phases = rng.uniform(0, 2 * np.pi, 6)
        mottle = np.sin(unit @ waves.T + phases).mean(axis=1)
        values = np.where(hit, self.brightness * (0.35 + 0.65 * lit) * (1 + 0.35 * mottle), 0.0)
        return t, values

    def translated(self, offset) -> Rock:
        d = validation.finite_vector("offset", offset, 3)
        return replace(self, centre=tuple(np.add(self.centre, d)))

    def points(self) -> dict[str, list[float]]:
        return {"centre": list(map(float, self.centre))}


def _plane_hit(origins: np.ndarray, directions: np.ndarray, point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    denominator = directions @ normal
    ok = np.abs(denominator) > 1e-12
    t = np.where(ok, ((point - origins) @ normal) / np.where(ok, denominator, 1.0), np.inf)
    return np.where(t > 0, t, np.inf)
