"""Streams of fish proposals over video frames with truth, for the association tests: a random calibrated
rig of a housing kind (tests/core/detection/stereo_scenes.py), fish swimming and turning 1-4 m in front of
it (some made to cross each other in the images or pass close in the water), their snout and fork imaged
through the housing with heavy-tailed pixel noise (Student's t, 3 degrees of freedom, scaled by the stated
σ: about one pick in twenty lies beyond 3σ), missed detections and false positives (3-D snout/fork pairs
that are no fish), each proposal intersected with its stated σ as the detection service measures it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tests.core.detection.stereo_scenes import SIZE, random_calibration
from usvips.core.detection.association import Sighting
from usvips.core.errors import UsvipsError
from usvips.core.measurements.batch import measure_picks_many

HOUSINGS = ("flat-port", "dome-port")


@dataclass
class Stream:
    """The sightings of a run in frame order, which fish each shows (−1: a false positive), and the frames
    looked at."""

    sightings: list[Sighting]
    fish: list[int]
    frames: list[int]


def _inside(pixels: np.ndarray, ok: np.ndarray) -> bool:
    return bool(ok.all() and np.all((pixels > 10) & (pixels < np.array(SIZE) - 10)))


def _paths(rng, rig, count: int, times: np.ndarray, cross: bool) -> np.ndarray:
    """(count, T, 2, 3) true snout and fork of each fish at each time: each swims at a constant speed
    (0.05-0.8 m/s) and turns at a constant rate (up to 0.8 rad/s about the vertical); with ``cross`` the
    second fish is aimed to cross the first one's place at mid-run (at another depth or within 0.2 m)."""
    out = []
    middle = times[len(times) // 2]
    while len(out) < count:
        start_pixel = np.array([rng.uniform(200, SIZE[0] - 200), rng.uniform(200, SIZE[1] - 200)])
        bundle = rig.left.rays(start_pixel[None])
        if not bundle.ok[0]:
            continue
        centre = bundle.origins[0] + rng.uniform(1.0, 4.0) * bundle.directions[0]
        heading = rng.normal(size=3)
        heading -= 0.7 * (heading @ bundle.directions[0]) * bundle.directions[0]
        heading /= np.linalg.norm(heading)
        speed, turn, length = rng.uniform(0.05, 0.8), rng.uniform(-0.8, 0.8), rng.uniform(0.2, 0.6)
        if cross and len(out) == 1:
            # the second fish passes the first one's mid-run place: along the same line of sight (crossing in
            # the images) at another depth, or beside it in the water
            target = out[0][len(times) // 2].mean(axis=0)
            if rng.uniform() < 0.5:
                ray = target - bundle.origins[0]
                target = bundle.origins[0] + ray * rng.uniform(0.6, 1.4)
            else:
                target = target + rng.normal(0, 0.2, 3)
            centre = target - speed * middle * heading
        up = np.array([0.0, 0.0, 1.0])
        body = []
        along, across = up * (up @ heading), heading - up * (up @ heading)
        side = np.cross(up, heading)
        for t in times:
            angle = turn * t
            rotated = along + across * np.cos(angle) + side * np.sin(angle)
            # the centre moves along the turning heading (integrated exactly for a constant turn rate)
            turned = (across * np.sin(angle) + side * (1 - np.cos(angle))) / turn if abs(turn) > 1e-9 else across * t
            travel = speed * (along * t + turned)
            mid = centre + travel
            body.append(np.vstack([mid + 0.5 * length * rotated, mid - 0.5 * length * rotated]))
        body = np.array(body)
        flat = body.reshape(-1, 3)
        if all(_inside(camera.project(flat).pixels, camera.project(flat).ok) for camera in (rig.left, rig.right)):
            out.append(body)
    return np.array(out)


def random_stream(rng: np.random.Generator, fish: int = 4, frames: int = 16, every: int = 1, fps: float = 25.0,
                  missed: float = 0.1, false_positives: float = 0.5, cross: bool = True) -> Stream:
    """A run of ``frames`` looked-at frames (every ``every``-th of a ``fps`` video) over ``fish`` fish."""
    calibration = random_calibration(rng, str(rng.choice(HOUSINGS)))
    rig = calibration.rig(0, "object")
    looked = [int(i * every) for i in range(frames)]
    times = np.array(looked, float) / fps
    paths = _paths(rng, rig, fish, times, cross)
    sigma = np.array([rng.uniform(0.4, 1.2), rng.uniform(0.4, 1.2)])
    bodies, owners, at = [], [], []
    for k, frame in enumerate(looked):
        seen = [(f, paths[f, k]) for f in range(fish) if rng.uniform() >= missed]
        for _ in range(rng.poisson(false_positives)):
            pixel = np.array([rng.uniform(100, SIZE[0] - 100), rng.uniform(100, SIZE[1] - 100)])
            bundle = rig.left.rays(pixel[None])
            snout = bundle.origins[0] + rng.uniform(1.0, 4.0) * bundle.directions[0]
            seen.append((-1, np.vstack([snout, snout + rng.normal(0, 0.2, 3)])))
        for owner, body in seen:
            bodies.append(body)
            owners.append(owner)
            at.append((frame, times[k]))
    flat = np.array(bodies).reshape(-1, 3)
    left, right = rig.left.project(flat), rig.right.project(flat)
    noise = sigma[None, None, :, None] * rng.standard_t(3, size=(len(bodies), 2, 2, 2))
    lefts, rights, kept = [], [], []
    for i in range(len(bodies)):
        rows = slice(2 * i, 2 * i + 2)
        if _inside(left.pixels[rows], left.ok[rows]) and _inside(right.pixels[rows], right.ok[rows]):
            lefts.append(left.pixels[rows] + noise[i, 0])
            rights.append(right.pixels[rows] + noise[i, 1])
            kept.append(i)
    owners, at = [owners[i] for i in kept], [at[i] for i in kept]
    measured = measure_picks_many(["length"] * len(lefts), calibration, lefts, rights, 0, "object",
                                  [sigma] * len(lefts))
    sightings, fish_of = [], []
    for m, owner, (frame, time_s) in zip(measured, owners, at, strict=True):
        if isinstance(m, UsvipsError):
            continue
        blocks = np.array([m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(2)])
        sightings.append(Sighting(frame, float(time_s), m.points, blocks))
        fish_of.append(owner)
    return Stream(sightings, fish_of, looked)
