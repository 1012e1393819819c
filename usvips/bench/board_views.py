"""Synthetic stereo views of a printed chessboard for the calibration's many-view bench rows and tests.

A 9 × 6 board of inner corners (24 mm squares) lies in the plane Z = 0 of the object frame (metres); a
stereo rig (about 10 cm baseline, 1280 × 960 px) films it from many poses: distances 0.35-0.8 m, tilts
up to about 30°, any roll, the board anywhere in the frame. Each pose is a station (pair label ``v<k>``).
The pixels are the calibration model's own (:class:`~usvips.core.calibration.model.StereoModel`, through
the housing for a water kind) at the true parameters, plus Gaussian noise: the truth is known exactly.
Poses where a corner leaves either image (or a ray cannot reach it) are drawn again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core import housing as housings
from usvips.core.adjustment import Parameter, PriorGroup
from usvips.core.calibration.model import StereoModel
from usvips.core.calibration.parameter_names import housing_parameter_names, symbol
from usvips.core.camera import EXTERIOR_PARAMETERS, Camera, Exterior
from usvips.core.housing import AirHousing
from usvips.core.interior import INTERIOR_PARAMETERS, Interior
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.rotation import rotation_matrix

COLUMNS, ROWS, SQUARE = 9, 6, 0.024          # inner corners and square size (m)
WIDTH, HEIGHT = 1280, 960                    # image size (px)
LEFT = Interior(f=1100.0, xp=652.0, yp=471.0, sy=1.0, k1=-0.09, k2=0.05)
RIGHT = Interior(f=1085.0, xp=628.0, yp=488.0, sy=1.0, k1=-0.07, k2=0.04)
RELATIVE = RelativeOrientation(0.10, 0.002, -0.004, 0.01, -0.06, 0.005)
#: phase 1's free interior symbols (the others fixed at their true values; k2 is free too here, as a
#: board's many tilted views determine it)
AIR_FREE = ("f", "xp", "yp", "sy", "k1", "k2")


def board() -> ControlPoints:
    """The board's inner corners (COLUMNS × ROWS) in its own plane Z = 0, metres, ids ``c<row>_<column>``."""
    u, v = np.meshgrid(np.arange(COLUMNS), np.arange(ROWS))
    xyz = np.column_stack([u.ravel() * SQUARE, v.ravel() * SQUARE, np.zeros(u.size)])
    return ControlPoints(tuple(f"c{r}_{c}" for r, c in zip(v.ravel(), u.ravel(), strict=True)), xyz)


@dataclass
class BoardViews:
    """A synthetic many-view board calibration: housing ``kind``, the control (board corners), the noisy
    observations, the true parameter values (the model's names) and the noise (px)."""

    kind: str
    control: ControlPoints
    observations: StereoObservations
    truth: dict[str, float]
    noise: float

    def model(self) -> StereoModel:
        return StereoModel(self.kind, self.control, self.observations, self.noise, (WIDTH, HEIGHT))


def _housing_truth(kind: str, rng: np.random.Generator) -> dict[str, float]:
    """True housing values: each parameter's default start, moved by half its prior sigma at random. A
    dome port's perspective centre sits 4 ± 1 mm behind the dome centre and within about a millimetre of
    its axis (the entrance pupil is hardest to place along the axis), as a lens is mounted in a dome. (A
    decentring mostly across the axis, whose symmetry axis points sideways, projects as well: the axial
    back-projection covers angles from the axis up to 180°.)"""
    cls = housings.kind(kind)
    out = {}
    for name in cls.calibration_names:
        spec = cls.spec(symbol(name))
        out[name] = spec.start + (0.5 * spec.sigma * rng.standard_normal() if spec.sigma else 0.0)
        if kind == "dome-port" and symbol(name) in ("dx", "dy", "dz"):
            out[name] = (0.004 if symbol(name) == "dz" else 0.0) + 0.001 * rng.standard_normal()
    return out


def _pose(rng: np.random.Generator) -> Exterior:
    """A left-camera pose looking at a point near the board (any roll, tilt up to ~30°)."""
    omega, phi = rng.uniform(-0.5, 0.5, 2)
    kappa = rng.uniform(-np.pi, np.pi)
    m = rotation_matrix(omega, phi, kappa)
    target = np.array([COLUMNS * SQUARE / 2, ROWS * SQUARE / 2, 0.0]) + rng.uniform(-0.1, 0.1, 3) * [1, 1, 0]
    centre = target + rng.uniform(0.35, 0.8) * (m.T @ np.array([0.0, 0.0, 1.0]))
    return Exterior(*centre, omega, phi, kappa)


def _visible(kind: str, control: ControlPoints, truth: dict[str, float], left: Exterior, right: Exterior,
             margin: float) -> bool:
    """Whether every corner of one view reaches both images through the housing, ``margin`` pixels
    inside the frame. (A dome port's iterative back-projection from its cold start does not converge
    for a few wide-angle corners of some poses: such views are drawn again.)"""
    n = len(control.ids)
    values = dict(truth)
    for p in EXTERIOR_PARAMETERS:
        values[f"{p}_l"], values[f"{p}_r"] = getattr(left, p), getattr(right, p)
    single = StereoObservations(tuple(control.ids), np.zeros((n, 2)), np.zeros((n, 2)), ("v",) * n)
    pixels, ok = StereoModel(kind, control, single, 1.0).evaluate(values)
    pixels = pixels.reshape(-1, 2)
    inside = (pixels > margin).all(axis=1) & (pixels[:, 0] < WIDTH - margin) & (pixels[:, 1] < HEIGHT - margin)
    return bool(ok.all() and inside.all())


def board_views(views: int, kind: str = "air", noise: float = 0.2, seed: int = 0) -> BoardViews:
    """``views`` stereo views of the board through housing ``kind`` (see the module docstring)."""
    rng = np.random.default_rng(seed)
    control = board()
    n = len(control.ids)
    truth = {f"{p}_{s}": getattr(i, p) for s, i in (("l", LEFT), ("r", RIGHT)) for p in INTERIOR_PARAMETERS}
    truth.update(_housing_truth(kind, rng))
    margin = 40.0
    poses: list[Exterior] = []
    rights: list[Exterior] = []
    draws = 0
    while len(poses) < views:
        draws += 1
        if draws > 50 * views:
            raise RuntimeError(f"cannot draw {views} board views that trace through {kind}")
        left = Camera(LEFT, _pose(rng), AirHousing(), WIDTH, HEIGHT)
        rig = StereoRig.from_relative(left, Camera(RIGHT, left.exterior, AirHousing(), WIDTH, HEIGHT), RELATIVE)
        if _visible(kind, control, truth, rig.left.exterior, rig.right.exterior, margin):
            poses.append(rig.left.exterior)
            rights.append(rig.right.exterior)
    for p in EXTERIOR_PARAMETERS:
        truth[f"{p}_l"], truth[f"{p}_r"] = getattr(poses[0], p), getattr(rights[0], p)
        for k, pose in enumerate(poses[1:], start=1):
            truth[f"{p}_l@v{k}"] = getattr(pose, p)
    labels = tuple(f"v{k}" for k in range(views) for _ in range(n))
    ids = tuple(control.ids) * views
    placeholder = np.zeros((views * n, 2))
    observations = StereoObservations(ids, placeholder, placeholder, labels)
    model = StereoModel(kind, control, observations, noise, (WIDTH, HEIGHT))
    computed, ok = model.evaluate(truth)
    if not ok.all():  # a ray that misses the housing: not the views this bench is about
        raise RuntimeError(f"{int((~ok).sum())} synthetic board corners cannot be traced through {kind}")
    pixels = computed + rng.normal(0.0, noise, computed.size)
    left_rows, right_rows = [], []
    for b, (_, side) in enumerate(model.block_keys):
        (left_rows if side == "l" else right_rows).append(pixels[model.blocks[b]].reshape(-1, 2))
    observations = StereoObservations(ids, np.vstack(left_rows), np.vstack(right_rows), labels)
    return BoardViews(kind, control, observations, truth, noise)


def start_parameters(scene: BoardViews, rng: np.random.Generator, phase: str = "air") -> list[Parameter]:
    """The model's parameters started from the truth perturbed (poses by ~1 cm and ~0.01 rad, the
    interior by a few pixels and its distortion by a few per cent; the housing by a fifth of its prior
    sigma, its prior at the kind's default start ± the kind's sigma; without a sigma, fixed at the truth).

    ``air``: the interior symbols of :data:`AIR_FREE` free, the others fixed at their true values.
    Water kinds: the interior weighted by a correlated prior (a phase-1 result: ±0.5 px on f, xp, yp,
    ±1e-3 on the rest, its mean the truth plus an error drawn from that), the housing's parameters with
    a prior where the kind gives one, else fixed."""
    model = scene.model()
    cls = housings.kind(scene.kind)
    housing_names = set(housing_parameter_names(scene.kind))
    interior = [f"{p}_{s}" for s in ("l", "r") for p in INTERIOR_PARAMETERS]
    group = None
    if phase != "air":
        chosen = [n for n in interior if symbol(n) in AIR_FREE]
        sigma = np.array([0.5 if symbol(n) in ("f", "xp", "yp") else 1e-3 for n in chosen])
        # a phase-1 result: the truth plus an error drawn from its own covariance
        mean = np.array([scene.truth[n] for n in chosen]) + sigma * rng.standard_normal(len(chosen))
        group = PriorGroup(tuple(chosen), mean, np.diag(sigma**2))
    out = []
    for name in model.parameter_names():
        value = scene.truth[name]
        key = symbol(name)
        if name in housing_names:
            spec = cls.spec(key)
            if not spec.sigma:
                out.append(Parameter(name, value, "fixed"))
                continue
            moved = value + 0.2 * spec.sigma * rng.standard_normal()
            if spec.lower is not None:
                moved = max(moved, spec.lower + 0.5 * (value - spec.lower))
            out.append(Parameter(name, moved, "prior", spec.start, spec.sigma, lower=spec.lower, upper=spec.upper))
        elif name in interior:
            if key not in AIR_FREE:
                out.append(Parameter(name, value, "fixed"))
            elif group is not None:
                k = group.names.index(name)
                out.append(Parameter(name, float(group.mean[k]), "prior", float(group.mean[k]),
                                     float(np.sqrt(group.covariance[k, k])), group=group))
            else:
                moved = value + (rng.normal(0, 3.0) if key in ("f", "xp", "yp") else
                                 rng.normal(0, 0.002) if key == "sy" else 0.05 * value * rng.standard_normal())
                out.append(Parameter(name, moved, "free"))
        else:
            out.append(Parameter(name, value + rng.normal(0, 0.01 if key in ("X0", "Y0", "Z0") else 0.01), "free"))
    return out
