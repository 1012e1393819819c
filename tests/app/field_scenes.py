"""Rendered stereo pairs of a 3-D field of discs with their truth, and projects holding them: the target
field's service, command and window are tested on these (several random poses and housings)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tests.core.scenes import HOUSINGS
from usvips.app.calibrations import store_calibration
from usvips.core.camera import Camera, Exterior
from usvips.core.interior import Interior
from usvips.core.observations import ControlPoints
from usvips.core.rig import RelativeOrientation, right_exterior
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.synth.render import Disc, Water, render
from usvips.io.images import write_image
from usvips.io.tables import write_control
from usvips.store.opening import create_project

WIDTH, HEIGHT = 320, 240
RADIUS = 0.025


def field(rng: np.random.Generator, count: int = 26) -> ControlPoints:
    """Discs in a 1.1 × 0.9 × 0.35 m box, at least 0.14 m apart; the first ten on the plane Z = 0."""
    points: list[np.ndarray] = []
    while len(points) < count:
        candidate = np.array([rng.uniform(-0.55, 0.55), rng.uniform(-0.45, 0.45),
                              0.0 if len(points) < 10 else rng.uniform(0.0, 0.35)])
        if all(np.linalg.norm(candidate[:2] - p[:2]) > 0.14 for p in points):
            points.append(candidate)
    return ControlPoints(tuple(f"T{i:02d}" for i in range(count)), np.array(points))


@dataclass
class StereoField:
    """A rendered pair: the control, the true cameras, the images and per side the true pixels of every
    disc centre and which are plainly visible (inside by a margin, no other disc near)."""

    control: ControlPoints
    cameras: dict[str, Camera]
    images: dict[str, np.ndarray]
    truth: dict[str, np.ndarray]
    visible: dict[str, np.ndarray]
    water: bool

    def clicks(self, rng: np.random.Generator, count: int = 7, noise_px: float = 2.0,
               planar_only: bool = False) -> dict[str, dict[str, tuple[float, float]]]:
        """``count`` visible targets per side (off the plane Z = 0 included unless ``planar_only``), each
        clicked within ``noise_px`` of its centre."""
        out = {}
        for side in ("left", "right"):
            pool = np.flatnonzero(self.visible[side])
            if planar_only:
                pool = pool[pool < 10]
            chosen = rng.choice(pool, min(count, len(pool)), replace=False)
            out[side] = {self.control.ids[i]: tuple(self.truth[side][i] + rng.uniform(-noise_px, noise_px, 2))
                         for i in chosen}
        return out


def stereo_field(rng: np.random.Generator, housing: str = "air", distance: float = 1.8,
                 width: int = WIDTH, height: int = HEIGHT) -> StereoField:
    control = field(rng)
    interior = Interior(f=350.0 * width / WIDTH, xp=width / 2 - 0.5 + rng.uniform(-5, 5),
                        yp=height / 2 - 0.5 + rng.uniform(-5, 5), k1=-0.08, k2=0.02, p1=2e-4, p2=-1e-4)
    left_pose = Exterior(rng.uniform(-0.1, 0.1) - 0.08, rng.uniform(-0.1, 0.1), distance + rng.uniform(-0.2, 0.2),
                         rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-np.pi, np.pi))
    relative = RelativeOrientation(0.16 + rng.uniform(-0.02, 0.02), 0.0, 0.0, 0.0, -0.05, 0.0)
    cameras = {"left": Camera(interior, left_pose, HOUSINGS[housing], width, height),
               "right": Camera(interior, right_exterior(left_pose, relative), HOUSINGS[housing], width, height)}
    water = housing != "air"
    medium = Water(attenuation=0.1, backscatter=40, blur=0.6, noise=1.5) if water else \
        Water(attenuation=0.0, backscatter=0.0, blur=0.5, noise=1.0)
    discs = [Disc(tuple(c), (0.0, 0.0, 1.0), RADIUS, 0.006) for c in control.xyz]
    images, truth, visible = {}, {}, {}
    for k, (side, camera) in enumerate(cameras.items()):
        images[side] = render(camera, discs, water=medium, supersample=2, background=70,
                              seed=int(rng.integers(1 << 30)) + k)
        truth[side], visible[side] = _truth(camera, control, width, height)
    return StereoField(control, cameras, images, truth, visible, water)


def _truth(camera: Camera, control: ControlPoints, width: int, height: int, margin: float = 12.0,
           apart: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    projection = camera.project(control.xyz)
    pixels = projection.pixels
    inside = projection.ok & (pixels[:, 0] > margin) & (pixels[:, 1] > margin) \
        & (pixels[:, 0] < width - 1 - margin) & (pixels[:, 1] < height - 1 - margin)
    gaps = np.linalg.norm(pixels[:, None] - pixels[None, :], axis=2)
    np.fill_diagonal(gaps, np.inf)
    return pixels, inside & (gaps.min(axis=1) > apart)


def field_project(folder: Path, scene: StereoField, label: str = "p1", store_control: bool = True,
                  calibrated: bool = False) -> tuple[Path, int | None]:
    """A project holding the scene's pair (its medium from the scene), its control unless told not (then
    written beside it as control.csv), and a calibration of the true cameras (its pose elsewhere: only
    the interior and housing are used) when ``calibrated``; returns the project's path and calibration id."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = {side: folder / f"{label}_{side}.png" for side in ("left", "right")}
    for side, path in paths.items():
        write_image(path, scene.images[side])
    write_control(folder / "control.csv", scene.control)
    path = folder / "field.usvips"
    calibration_id = None
    with create_project(path) as project:
        project.add_image_pairs([(label, paths["left"], paths["right"])], medium="water" if scene.water else "air")
        if store_control:
            project.set_control(scene.control)
        if calibrated:
            moved = {side: c.with_exterior(Exterior(0.0, 0.0, 1.0)) for side, c in scene.cameras.items()}
            rig = StereoCalibration(moved["left"], moved["right"], ("elsewhere",), (moved["left"].exterior,),
                                    RelativeOrientation(0.16), "water" if scene.water else "air", 0.3)
            calibration_id = store_calibration(project, "earlier", rig)
    return path, calibration_id
