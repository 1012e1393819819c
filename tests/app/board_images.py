"""Rendered stereo views of a chessboard through a rig of known truth (image files), for the board
calibration tests of the app, the command line and the window."""

from __future__ import annotations

import dataclasses

import numpy as np

from tests.core.board_scenes import random_rig
from usvips.core.calibration_targets import kind
from usvips.core.camera import Exterior
from usvips.core.synth.boards import BoardPose, board_pixels, render_board
from usvips.io.images import write_image

SIZE = (480, 360)
MARGIN = 12.0


def board_poses(rig, board, rng, count: int, distances: tuple[float, float]) -> list[BoardPose]:
    """Board poses seen whole by both cameras (a margin from the frame), tilted 15–40° in all directions."""
    stereo = rig.at(Exterior(0.0, 0.0, 0.0))
    poses = []
    for _ in range(2000):
        if len(poses) == count:
            break
        distance = rng.uniform(*distances)
        disparity = stereo.left.interior.f * rig.relative.base[0] / distance
        pixel = (SIZE[0] / 2 + disparity / 2 + rng.uniform(-60, 60), SIZE[1] / 2 + rng.uniform(-50, 50))
        pose = BoardPose.facing(stereo.left, (0.12, 0.075), pixel, distance, tilt=np.radians(rng.uniform(15, 40)),
                                tilt_direction=rng.uniform(0, 2 * np.pi), spin=rng.uniform(-0.3, 0.3))
        inside = True
        for camera in (stereo.left, stereo.right):
            _, px, ok = board_pixels(camera, board, pose)
            inside &= bool(ok.all() and (px.min(axis=0) > MARGIN).all()
                           and (px < np.array(SIZE) - MARGIN).all())
        if inside:
            poses.append(pose)
    assert len(poses) == count, "the scene cannot place the board in both images"
    return poses


def render_pairs(folder, rig, board, poses, prefix: str) -> list[tuple]:
    stereo = rig.at(Exterior(0.0, 0.0, 0.0))
    pairs = []
    for k, pose in enumerate(poses):
        paths = []
        for side, camera in (("L", stereo.left), ("R", stereo.right)):
            path = folder / f"{prefix}{side}{k}.png"
            write_image(path, render_board(camera, board, pose, supersample=2, seed=k))
            paths.append(path)
        pairs.append(tuple(paths))
    return pairs


def air_scene(folder, views: int, seed: int = 24):
    """(board, rig, pairs): ``views`` rendered pairs of a 9 × 6 chessboard (30 mm squares) in air through
    a random rig of 12 cm baseline, written under ``folder``."""
    rng = np.random.default_rng(seed)
    board = kind("chessboard")(9, 6, 0.03)
    rig = random_rig(rng, SIZE)
    rig = dataclasses.replace(rig, relative=dataclasses.replace(rig.relative, bx=0.12, phi=-0.05))
    return board, rig, render_pairs(folder, rig, board, board_poses(rig, board, rng, views, (0.6, 0.9)), "a"), rng
