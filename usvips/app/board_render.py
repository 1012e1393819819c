"""Rehearsing a calibration: a printed target rendered through any housing kind, with its truth
(``usvips render --target T --housing KIND …``; issue 33, item 6).

:func:`render_board_views` draws board views (still image pairs, and optionally a stereo video of the board
moving slowly) as a rig of known cameras sees them through a housing of the registry, and writes beside them
the true pixels of the target's points and the truth (interiors, relative orientation, housings, each
view's board pose). The board poses depend on the ``seed`` only, not on the housing: the same seed through
``air`` and through ``flat-port`` gives the same view in air and under water (the cameras unmoved), which is
how phase 2 in a tank is rehearsed (``n3 = 1`` renders the empty tank's wall).

Everything is rendered into a staging folder beside ``out`` and moved in only when complete. Conventions:
metres; radians; pixels x right, y down, origin at the centre of the top-left pixel; the left camera at the
origin of the object frame, looking along −z.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvips.app.render import _publish
from usvips.core import housing as housings
from usvips.core.calibration.parameter_names import symbol
from usvips.core.calibration_targets import CalibrationTarget
from usvips.core.camera import Camera
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.interior import Interior
from usvips.core.observations import StereoObservations
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.stereo_calibration import RIG_ORIGIN, StereoCalibration
from usvips.core.synth.boards import BoardPose, board_pixels, render_board
from usvips.io.atomic import OutputFileError, replacing, write_text_atomic
from usvips.io.images import write_image
from usvips.io.tables import write_observations
from usvips.io.target_file import read_target
from usvips.io.video import write_video

Progress = Callable[[float, str], None]

#: Draws of a board pose per view before the views are refused as not fitting the images.
POSE_DRAWS = 200
#: At most this many still pairs and video frames, and image sides of at most this many pixels: beyond them a
#: rehearsal would render for days (a mistyped count is refused, not started)
MAX_VIEWS, MAX_VIDEO_FRAMES, MAX_SIDE = 1000, 100_000, 16384


@dataclass(frozen=True)
class Rehearsal:
    """What is rendered: ``views`` still pairs, ``video_frames`` frames of a stereo video (0: none) at
    ``fps``, the board at ``distances`` (m, from the left camera) tilted by ``tilts`` (degrees), images of
    ``size`` (width, height) px, ``supersample`` samples per pixel side, ``noise`` grey levels, ``seed``."""

    views: int = 15
    video_frames: int = 0
    fps: int = 10
    distances: tuple[float, float] = (0.5, 1.0)
    tilts: tuple[float, float] = (15.0, 40.0)
    size: tuple[int, int] = (1280, 960)
    supersample: int = 3
    noise: float = 1.0
    seed: int = 0

    def check(self) -> None:
        """Refuse values that cannot be rendered, naming the parameter."""
        if self.video_frames < 0:
            raise InvalidParameterError("video_frames", f"must be 0 or more frames, got {self.video_frames}")
        if self.views < 0 or self.views + self.video_frames == 0:
            raise InvalidParameterError("views", "render at least one view or video frame (none is negative)")
        if self.views > MAX_VIEWS:
            raise InvalidParameterError("views", f"at most {MAX_VIEWS} still pairs, got {self.views}")
        if self.video_frames > MAX_VIDEO_FRAMES:
            raise InvalidParameterError("video_frames", f"at most {MAX_VIDEO_FRAMES} frames, got {self.video_frames}")
        if not 0 < self.distances[0] <= self.distances[1] or not np.all(np.isfinite(self.distances)):
            raise InvalidParameterError("distances", f"must be 0 < nearest <= farthest (metres), got {self.distances}")
        if not 0 <= self.tilts[0] <= self.tilts[1] < 80:
            raise InvalidParameterError("tilts", f"must be 0 <= least <= most < 80 degrees, got {self.tilts}")
        if min(self.size) < 64 or max(self.size) > MAX_SIDE:
            raise InvalidParameterError("size", f"each side must be 64 to {MAX_SIDE} pixels, got {self.size}")
        if not 1 <= self.supersample <= 8:
            raise InvalidParameterError("supersample", f"must be 1 to 8, got {self.supersample}")
        if not (np.isfinite(self.noise) and self.noise >= 0):
            raise InvalidParameterError("noise", f"must be >= 0 grey levels, got {self.noise}")
        if not 1 <= self.fps <= 240:
            raise InvalidParameterError("fps", f"must be a whole number 1 to 240, got {self.fps}")
        if not 0 <= self.seed < 2**63:
            raise InvalidParameterError("seed", f"must be a whole number 0 to 2**63 - 1, got {self.seed}")


def default_cameras(size: tuple[int, int]) -> tuple[Interior, Interior, RelativeOrientation]:
    """A rig on paper: focal length 0.9 × the image width, principal point at the centre, k1 = −0.05, both
    cameras alike, 15 cm apart and toed in by 3°."""
    width, height = size
    interior = Interior(f=0.9 * width, xp=width / 2, yp=height / 2, k1=-0.05)
    return interior, interior, RelativeOrientation(0.15, phi=np.radians(-3.0))


def housing_pair(kind_name: str, values: dict[str, float], relative: RelativeOrientation):
    """The left and right housings of ``kind_name`` with the given symbol values (both cameras' alike),
    the rest at the kind's defaults; an unknown kind or symbol, or an unphysical value, is named."""
    kind = housings.kind(kind_name)
    known = {s.symbol for s in kind.specs}
    unknown = sorted(set(values) - known)
    if unknown:
        raise InvalidParameterError(unknown[0], f"is not a parameter of the {kind.kind} housing; parameters: "
                                    f"{', '.join(sorted(known)) or 'none'}")
    if not kind.calibration_names:
        one = kind.from_symbols(values)
        return one, one
    named = {name: float(values.get(symbol(name), kind.spec(symbol(name)).start)) for name in kind.calibration_names}
    rotation = relative.rotation
    return kind.build(named, rotation, -rotation @ relative.base)


def _rig(left: Interior, right: Interior, relative: RelativeOrientation, housing_l, housing_r,
         size: tuple[int, int]) -> StereoRig:
    first = Camera(left, RIG_ORIGIN, housing_l, *size)
    return StereoRig.from_relative(first, Camera(right, RIG_ORIGIN, housing_r, *size), relative)


def _pose(camera: Camera, target: CalibrationTarget, rng: np.random.Generator, plan: Rehearsal) -> BoardPose:
    centre = target.control_points().xyz.mean(axis=0)
    width, height = plan.size
    pixel = (rng.uniform(0.3, 0.7) * width, rng.uniform(0.3, 0.7) * height)
    return BoardPose.facing(camera, (centre[0], centre[1]), pixel, rng.uniform(*plan.distances),
                            tilt=np.radians(rng.uniform(*plan.tilts)), tilt_direction=rng.uniform(0, 2 * np.pi),
                            spin=rng.uniform(-0.3, 0.3))


def _seen(rig: StereoRig, target: CalibrationTarget, pose: BoardPose) -> bool:
    """Every point of the target in both images (inside by a margin of 8 px)."""
    for camera in (rig.left, rig.right):
        _, pixels, visible = board_pixels(camera, target, pose)
        inside = (pixels[:, 0] > 8) & (pixels[:, 1] > 8) & (pixels[:, 0] < camera.width - 9) & (
            pixels[:, 1] < camera.height - 9)
        if not np.all(visible & inside):
            return False
    return True


def board_poses(target: CalibrationTarget, air_rig: StereoRig, rig: StereoRig, plan: Rehearsal,
                count: int, rng: np.random.Generator) -> list[BoardPose]:
    """``count`` poses drawn with the air rig (so that they depend on the seed only) that show every point
    of the target in both images of ``rig``; a target that does not fit at the distances asked is named."""
    poses: list[BoardPose] = []
    draws = 0
    while len(poses) < count:
        draws += 1
        if draws > POSE_DRAWS * count:
            raise DegenerateGeometryError(
                f"the target does not fit whole in both images at {plan.distances[0]:g}-{plan.distances[1]:g} m "
                f"(found {len(poses)} of {count} views in {draws - 1} tries): render it farther, smaller or less "
                "tilted")
        pose = _pose(air_rig.left, target, rng, plan)
        if _seen(rig, target, pose):
            poses.append(pose)
    return poses


def _view_truth(label: str, pose: BoardPose) -> dict:
    return {"label": label, "board_rotation": pose.rotation.tolist(), "board_position": pose.position.tolist()}


def _interior_truth(interior: Interior) -> dict:
    return {k: float(getattr(interior, k)) for k in ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2", "k3")}


def render_board_views(target: CalibrationTarget | str | Path, out: str | Path, housing: str = "air",
                       housing_values: dict[str, float] | None = None, plan: Rehearsal | None = None,
                       calibration: StereoCalibration | None = None, replace: bool = False,
                       progress: Progress | None = None) -> dict:
    """Render ``plan``'s board views of ``target`` through ``housing`` (a registered kind; ``housing_values``
    symbol → value for both cameras, the rest at the kind's defaults) into the folder ``out``: ``left/`` and
    ``right/`` images ``view_NNN.png``, ``observations.csv`` (the true pixels, ``id,xl,yl,xr,yr,pair``, one
    pair label per view), ``truth.json`` and, with video frames, ``video_left.avi`` / ``video_right.avi``
    (synchronised; their true pixels in ``video_observations.csv``, pair = ``video-<frame>``). The cameras
    are ``calibration``'s (its interiors and relative orientation) or :func:`default_cameras`. Returns the
    truth. A file of ``out`` that holds a USVIPS calibration or project is replaced only with ``replace``."""
    plan = plan or Rehearsal()
    plan.check()
    if isinstance(target, str | Path):
        target_path = str(target)
        target = read_target(target)
    else:
        target_path = None
    if not hasattr(target, "ink"):
        raise InvalidParameterError("target", f"a {getattr(target, 'kind', 'target')} cannot be printed and rendered "
                                    "(a board can: chessboard, ChArUco, circle or marker grid)")
    if calibration is not None:
        left, right, relative = calibration.left.interior, calibration.right.interior, calibration.relative
    else:
        left, right, relative = default_cameras(plan.size)
    housing_l, housing_r = housing_pair(housing, dict(housing_values or {}), relative)
    air = housings.kind("air").from_symbols({})
    air_rig = _rig(left, right, relative, air, air, plan.size)
    rig = _rig(left, right, relative, housing_l, housing_r, plan.size)
    if not rig.left.rays(np.array([[plan.size[0] / 2, plan.size[1] / 2]])).ok[0]:
        raise DegenerateGeometryError(f"the {housing} housing lets no ray through the image centre: check its values")
    rng = np.random.default_rng(plan.seed)
    stills = board_poses(target, air_rig, rig, plan, plan.views, rng)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputFileError(str(out), "must be a folder (it is a file)")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.render-", dir=str(out.parent)))
    except OSError as error:
        raise OutputFileError(str(out), f"cannot create the output folder: {error.strerror or error}") from None
    truth = {"target": target_path, "housing": {"kind": housing, "left": housing_l.to_values(),
                                                "right": housing_r.to_values()},
             "cameras": {"left": _interior_truth(left), "right": _interior_truth(right)},
             "relative_orientation": {k: float(getattr(relative, k)) for k in
                                      ("bx", "by", "bz", "omega", "phi", "kappa")},
             "frame": "the left camera at the origin looking along -z; board point X = board_rotation · x + "
                      "board_position (metres)",
             "size": list(plan.size), "seed": plan.seed, "views": [], "video": None}
    total = plan.views + plan.video_frames
    try:
        (staging / "left").mkdir()
        (staging / "right").mkdir()
        truth["views"] = _stills(target, rig, stills, plan, staging, progress, total)
        if plan.video_frames:
            truth["video"] = _video(target, air_rig, rig, plan, staging, rng, progress, total)
        write_text_atomic(staging / "truth.json", json.dumps(truth, indent=2) + "\n")
        targets = [out / f.relative_to(staging) for f in staging.rglob("*") if f.is_file()] if out.exists() else []
        targets = [t for t in targets if t.exists() or t.is_symlink()]
        with replacing(targets, [target_path] if target_path else [], replace=replace):
            _publish(staging, out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return truth


def _observations(target: CalibrationTarget, rig: StereoRig, poses: list[BoardPose], labels: list[str]
                  ) -> StereoObservations:
    ids, left, right, pairs = [], [], [], []
    for pose, label in zip(poses, labels, strict=True):
        names, pl, _ = board_pixels(rig.left, target, pose)
        _, pr, _ = board_pixels(rig.right, target, pose)
        ids += list(names)
        left.append(pl)
        right.append(pr)
        pairs += [label] * len(names)
    return StereoObservations(tuple(ids), np.vstack(left), np.vstack(right), tuple(pairs))


def _image(camera: Camera, target, pose: BoardPose, plan: Rehearsal, seed: int) -> np.ndarray:
    return render_board(camera, target, pose, plan.size, supersample=plan.supersample, noise=plan.noise, seed=seed)


def _stills(target, rig: StereoRig, poses: list[BoardPose], plan: Rehearsal, folder: Path,
            progress: Progress | None, total: int) -> list[dict]:
    labels = [f"view_{k:03d}" for k in range(len(poses))]
    for k, (pose, label) in enumerate(zip(poses, labels, strict=True)):
        if progress is not None:
            progress(k / total, f"view {k + 1} of {len(poses)}")
        for side, camera in (("left", rig.left), ("right", rig.right)):
            write_image(folder / side / f"{label}.png", _image(camera, target, pose, plan,
                                                               plan.seed * 10_000 + 2 * k + (side == "right")))
    if poses:
        write_observations(folder / "observations.csv", _observations(target, rig, poses, labels))
    return [_view_truth(label, pose) for label, pose in zip(labels, poses, strict=True)]


def _video(target, air_rig: StereoRig, rig: StereoRig, plan: Rehearsal, folder: Path, rng: np.random.Generator,
           progress: Progress | None, total: int) -> dict:
    """The board moving slowly through a few key poses (each seen whole), interpolated between them."""
    keys = board_poses(target, air_rig, rig, plan, max(2, plan.video_frames // 20 + 1), rng)
    poses = []
    for j in range(plan.video_frames):
        s = j / max(plan.video_frames - 1, 1) * (len(keys) - 1)
        k = min(int(s), len(keys) - 2)
        poses.append(_between(keys[k], keys[k + 1], s - k))
    labels = [f"video-{j}" for j in range(plan.video_frames)]
    for side, camera in (("left", rig.left), ("right", rig.right)):
        def frames(camera=camera, side=side):
            for j, pose in enumerate(poses):
                if progress is not None and side == "right":
                    progress((plan.views + j) / total, f"video frame {j + 1} of {plan.video_frames}")
                yield _image(camera, target, pose, plan, plan.seed * 10_000 + 5_000 + 2 * j + (side == "right"))

        write_video(folder / f"video_{side}.avi", frames(), plan.fps)
    write_observations(folder / "video_observations.csv", _observations(target, rig, poses, labels))
    return {"fps": plan.fps, "frames": plan.video_frames, "frame_offset": 0,
            "poses": [_view_truth(label, pose) for label, pose in zip(labels, poses, strict=True)]}


def _between(a: BoardPose, b: BoardPose, s: float) -> BoardPose:
    """The pose a share ``s`` (0–1) of the way from ``a`` to ``b`` (rotation along the geodesic)."""
    import cv2

    relative = b.rotation @ a.rotation.T
    vector, _ = cv2.Rodrigues(relative)
    step, _ = cv2.Rodrigues(vector * s)
    return BoardPose(step @ a.rotation, (1 - s) * a.position + s * b.position)


def parse_housing_values(items: list[str]) -> dict[str, float]:
    """``NAME=VALUE`` items → {symbol: value}; a malformed item or a value that is not a finite number is an
    :class:`InvalidParameterError` naming it."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not sep or not name or not np.isfinite(number):
            raise InvalidParameterError("housing value", f"expected NAME=VALUE with a finite number, got {item!r}")
        out[name.strip()] = number
    return out

