"""Proposals of successive video frames joined into fish: which sighting in a later frame is the same fish
as one in an earlier frame, decided by the 3-D keypoints (e.g. snout and fork) and their covariance alone.

A fish cannot move faster than ``max_speed`` (m/s): between two sightings Δt seconds apart, each of its
keypoints moves at most its *reach* r = max_speed · Δt (a bending tail's fork included: the speed is of any
body point). A later sighting is a **candidate** for a track (the sightings joined so far, ending in its
last sighting) when, for every keypoint, the distance d between the two 3-D points exceeds the reach by at
most ``gate`` standard deviations of that distance's error,

    e = max(0, d − r) / σ_d ≤ gate,   σ_d² = uᵀ (C₁ + C₂) u,  u the unit vector between the points,

C₁, C₂ the points' covariances (the intersections' stated σ: pointing and calibration). Among candidates,
one assignment over the frame (:func:`scipy.optimize.linear_sum_assignment`, not greedy) joins tracks to
sightings by the squared Mahalanobis distance of the keypoints' displacement with the motion taken as
isotropic, σ_m = r / 3 per axis (so the closest in σ wins).

Honesty before completeness: a link is made only when it is **unambiguous** — the track has no other
candidate in the frame and the sighting is a candidate of no other track seen lately (within ``max_missed``
+ 1 looked-at frames), ended tracks included: a track ended by an ambiguity may be the very fish a later
sighting shows while the fish it was confused with goes unseen. Two fish near enough to be taken for each
other (crossing, schooling) end their tracks there and start new ones: the fish may then be counted twice,
never two fish counted as one. A track whose fish is not seen stays open for ``max_missed`` looked-at
frames (its reach grows with Δt), then ends.

Units: metres, seconds; frames are whatever whole numbers the caller looks at, in increasing order.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from usvips.core import validation
from usvips.core.errors import InvalidParameterError

#: the default largest speed (m/s) of any keypoint of a fish between two looked-at frames: above the
#: cruising speed of most survey fish (0.5-1.5 body lengths per second, under 1 m/s for fish below 0.6 m),
#: below a burst; a faster fish's track breaks (it is counted again), it is never joined to another fish
DEFAULT_MAX_SPEED_M_S = 1.5
#: how many standard deviations beyond its reach a keypoint may lie and still be the same fish
DEFAULT_GATE_SIGMA = 3.0
#: looked-at frames a track may miss its fish (not detected) and still be continued
DEFAULT_MAX_MISSED = 1


@dataclass(frozen=True)
class Sighting:
    """One proposal of one fish in one looked-at frame: the ``frame`` (a whole number), its time ``time_s``
    (s), its keypoints' 3-D ``points`` (K, 3) m and their covariance ``covariance`` (K, 3, 3) m² (each
    keypoint's own block)."""

    frame: int
    time_s: float
    points: np.ndarray
    covariance: np.ndarray

    def __post_init__(self) -> None:
        points = np.asarray(self.points, float)
        covariance = np.asarray(self.covariance, float)
        if points.ndim != 2 or points.shape[1] != 3 or covariance.shape != (len(points), 3, 3):
            raise InvalidParameterError("sighting", f"needs (K, 3) points and (K, 3, 3) covariance blocks, got "
                                                    f"{points.shape} and {covariance.shape}")
        if not (np.all(np.isfinite(points)) and np.all(np.isfinite(covariance)) and np.isfinite(self.time_s)):
            raise InvalidParameterError("sighting", f"frame {self.frame}: its points, covariance and time must be "
                                                    "finite")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "covariance", covariance)


@dataclass(frozen=True)
class Association:
    """What joining found: ``chains`` — each fish's sightings (indices into the sightings given) in frame
    order, single sightings included — and ``ambiguous``: how many candidate links were refused because
    another fish was as near (the tracks were ended there)."""

    chains: tuple[tuple[int, ...], ...]
    ambiguous: int = 0

    @property
    def joined(self) -> tuple[tuple[int, ...], ...]:
        """The chains of two or more sightings: fish seen on several frames."""
        return tuple(c for c in self.chains if len(c) > 1)


def excess_sigma(first: Sequence[Sighting], second: Sequence[Sighting], reach_m: np.ndarray) -> np.ndarray:
    """(len(first), len(second), K) the normalised excess of each keypoint's displacement over its reach
    (``reach_m``: (len(first),) m, one per first sighting): max(0, d − r) / σ_d (see the module docstring)."""
    delta, total = _pairs(first, second)
    distance = np.linalg.norm(delta, axis=-1)
    unit = delta / np.where(distance > 0, distance, 1.0)[..., None]
    along = np.einsum("...i,...ij,...j->...", unit, total, unit)
    # points that did not move: no direction; their excess is 0 whatever σ_d is (the mean variance)
    along = np.where(distance > 0, along, np.trace(total, axis1=-2, axis2=-1) / 3)
    if np.any(along <= 0):
        raise InvalidParameterError("covariance", "a sighting's keypoint covariance is not positive definite")
    return np.maximum(distance - np.asarray(reach_m, float)[:, None, None], 0.0) / np.sqrt(along)


def motion_cost(first: Sequence[Sighting], second: Sequence[Sighting], reach_m: np.ndarray) -> np.ndarray:
    """(len(first), len(second)) the squared Mahalanobis distance of the keypoints' displacements, summed
    over the keypoints, with an isotropic motion of σ = reach / 3 per axis added to the points' covariance."""
    delta, total = _pairs(first, second)
    motion = (np.asarray(reach_m, float) / 3.0) ** 2
    total = total + motion[:, None, None, None, None] * np.eye(3)
    return np.einsum("...i,...i->...", delta, np.linalg.solve(total, delta[..., None])[..., 0]).sum(axis=-1)


def _pairs(first: Sequence[Sighting], second: Sequence[Sighting]) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([s.points for s in first], float)
    b = np.array([s.points for s in second], float)
    if a.shape[1:] != b.shape[1:]:
        raise InvalidParameterError("sighting", f"sightings have different keypoints: {a.shape[1:]} and "
                                                f"{b.shape[1:]}")
    ca = np.array([s.covariance for s in first], float)
    cb = np.array([s.covariance for s in second], float)
    return b[None] - a[:, None], ca[:, None] + cb[None]


def associate(sightings: Sequence[Sighting], max_speed_m_s: float = DEFAULT_MAX_SPEED_M_S,
              gate_sigma: float = DEFAULT_GATE_SIGMA, max_missed: int = DEFAULT_MAX_MISSED,
              frames: Sequence[int] | None = None) -> Association:
    """Join ``sightings`` into fish (see the module docstring). ``frames``: every frame looked at, in
    increasing order (a frame where nothing was seen still counts towards ``max_missed``); default the
    sightings' own frames. Two sightings of one frame are never joined; a sighting whose frame is not in
    ``frames``, or a later frame whose time is not later, is an :class:`InvalidParameterError`."""
    max_speed = validation.positive("max_speed", max_speed_m_s)
    gate = validation.positive("gate_sigma", gate_sigma)
    if int(max_missed) < 0:
        raise InvalidParameterError("max_missed", f"must be a whole number >= 0, got {max_missed}")
    looked = sorted({s.frame for s in sightings}) if frames is None else [int(f) for f in frames]
    if any(b <= a for a, b in zip(looked, looked[1:], strict=False)):
        raise InvalidParameterError("frames", "must be increasing")
    position = {f: i for i, f in enumerate(looked)}
    by_frame: dict[int, list[int]] = {}
    for index, sighting in enumerate(sightings):
        if sighting.frame not in position:
            raise InvalidParameterError("sighting", f"frame {sighting.frame} is not among the frames looked at")
        by_frame.setdefault(sighting.frame, []).append(index)
    tracks: list[list[int]] = []  # every chain so far, in the order started
    ended: set[int] = set()  # chains that can take no further sighting
    ambiguous = 0
    window = int(max_missed) + 1
    for frame in looked:
        now = by_frame.get(frame, [])
        # every chain seen lately competes for this frame's sightings, ended ones too: a chain ended by an
        # ambiguity may be the fish that a later sighting shows (its own continuation missed)
        age = {c: position[frame] - position[sightings[tracks[c][-1]].frame] for c in range(len(tracks))}
        ended |= {c for c, a in age.items() if a > window}
        recent = [c for c, a in age.items() if a <= window]
        links, contested = _links(sightings, [tracks[c] for c in recent], [c not in ended for c in recent], now,
                                  max_speed, gate)
        ambiguous += len(contested)
        taken = set()
        for row, sighting_index in links:
            tracks[recent[row]].append(sighting_index)
            taken.add(sighting_index)
        ended |= {recent[row] for row in contested}
        tracks += [[i] for i in now if i not in taken]
    chains = sorted((tuple(t) for t in tracks), key=lambda c: c[0])
    return Association(tuple(chains), ambiguous)


def _links(sightings: Sequence[Sighting], tracks: list[list[int]], open_: list[bool], now: list[int],
           max_speed: float, gate: float) -> tuple[list[tuple[int, int]], list[int]]:
    """(track row, sighting) links made in one frame, and the open track rows refused a link because it was
    ambiguous (the track, or its candidate, had another candidate); an ended track only competes."""
    if not tracks or not now:
        return [], []
    last = [sightings[t[-1]] for t in tracks]
    current = [sightings[i] for i in now]
    dt = np.array([[c.time_s - p.time_s for c in current] for p in last])
    if np.any(dt <= 0):
        raise InvalidParameterError("time_s", "a later frame's time must be later than an earlier frame's")
    # the reach depends on the track's Δt to this frame: all sightings of one frame share one time
    reach = max_speed * dt[:, 0]
    candidate = np.all(excess_sigma(last, current, reach) <= gate, axis=-1)
    if not candidate.any():
        return [], []
    cost = motion_cost(last, current, reach)
    rows, cols = linear_sum_assignment(np.where(candidate, cost, np.max(cost[candidate]) + 1.0))
    per_track, per_sighting = candidate.sum(axis=1), candidate.sum(axis=0)
    links = [(int(r), now[int(c)]) for r, c in zip(rows, cols, strict=True)
             if open_[r] and candidate[r, c] and per_track[r] == 1 and per_sighting[c] == 1]
    linked = {r for r, _ in links}
    contested = [r for r in range(len(tracks)) if open_[r] and per_track[r] and r not in linked]
    return links, contested
