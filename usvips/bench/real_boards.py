"""Real board sets measured against OpenCV: views found, focal lengths, baseline, held-out distances.

A *board set* is a folder of stereo image pairs of a printed board (``left*`` and ``right*`` images paired
in name order) with ``board.json``, the board's target description (:mod:`usvips.io.target_file`). For a
set, :func:`compare_set` measures, side by side with OpenCV computed in the same run (never a stored
number):

* **views found**: the images in which OpenCV's bare detectors find the board (``findChessboardCorners``
  or ``findChessboardCornersSB`` without flags), in which ours does (the kind's cascade), and the pairs
  our one detection loop keeps;
* **calibration**: our phase-1 calibration from the views we keep (with OpenCV's five distortion terms
  freed: k1, k2, k3, p1, p2, as OpenCV estimates them) against OpenCV's usual pipeline on the pairs it
  finds (``findChessboardCorners`` + ``cornerSubPix``, ``calibrateCamera`` per camera, then
  ``stereoCalibrate``): both focal lengths and the baseline, as relative differences;
* **held-out known distances**: the same share of the views held out for both (chosen by
  :func:`usvips.core.calibration.validation.holdout_views` over the pairs both find), each calibrated on
  the rest; the held-out views' adjacent corners intersected (ours) or triangulated (OpenCV's), RMS of
  the relative length error (corners where OpenCV's iterative undistortion does not invert are left out
  of OpenCV's figure and counted).

``usvips bench`` runs it on every set under the folder named by ``$USVIPS_REAL_BOARDS``, else on the sets
committed with the tests (``tests/data/real_boards``: public, licensed, each with its SOURCE.md; the tests
in ``tests/app/test_real_board_sets.py`` hold them to issue 33's acceptance).

Conventions: pixels x right, y down; lengths in the board description's metres.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from usvips.app.board_calibration import calibrate_views
from usvips.app.target_views import detect_views
from usvips.core.calibration import CalibrationOptions
from usvips.core.calibration.validation import holdout_views
from usvips.core.calibration_targets.kinds._board import to_grey8
from usvips.io.images import read_image
from usvips.io.target_file import read_target

#: image files a set may hold
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: the distortion terms our calibration frees beyond its default (OpenCV's five terms)
FREED = ("k2", "k3", "p1", "p2")
#: the share of views held out for the known-distance comparison
HOLDOUT_SHARE = 0.2


def _natural(path: Path) -> tuple:
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in re.split(r"(\d+)", path.name) if p)


def set_pairs(folder: Path) -> list[tuple[Path, Path]]:
    """The (left, right) image pairs of a set: ``left*`` and ``right*`` files (any case; ``L*``/``R*`` too)
    paired in natural name order."""
    files = [p for p in sorted(folder.iterdir()) if p.suffix.lower() in IMAGE_SUFFIXES]
    sides = {side: sorted((p for p in files if p.name.lower().startswith(prefixes)), key=_natural)
             for side, prefixes in (("left", ("left", "l")), ("right", ("right", "r")))}
    if len(sides["left"]) != len(sides["right"]) or not sides["left"]:
        raise ValueError(f"{folder}: {len(sides['left'])} left and {len(sides['right'])} right images")
    return list(zip(sides["left"], sides["right"], strict=True))


def opencv_bare(grey: np.ndarray, pattern: tuple[int, int]) -> np.ndarray | None:
    """OpenCV's usual chessboard corners: ``findChessboardCorners`` refined by ``cornerSubPix`` (11 × 11,
    as OpenCV's calibration sample), else ``findChessboardCornersSB`` without flags; None when neither
    finds the board."""
    found, corners = cv2.findChessboardCorners(grey, pattern)
    if found:
        criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
        return cv2.cornerSubPix(grey, corners, (11, 11), (-1, -1), criteria).reshape(-1, 2)
    found, corners = cv2.findChessboardCornersSB(grey, pattern)
    return corners.reshape(-1, 2) if found else None


def _opencv_calibration(objects: list, lefts: list, rights: list, size: tuple[int, int]) -> dict:
    """OpenCV's usual stereo calibration: ``calibrateCamera`` per camera, then ``stereoCalibrate`` from those
    interiors (5-term distortion)."""
    _, k1, d1, _, _ = cv2.calibrateCamera(objects, lefts, size, None, None)
    _, k2, d2, _, _ = cv2.calibrateCamera(objects, rights, size, None, None)
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-9)
    _, k1, d1, k2, d2, rotation, translation, *_ = cv2.stereoCalibrate(
        objects, lefts, rights, k1, d1, k2, d2, size, flags=cv2.CALIB_USE_INTRINSIC_GUESS, criteria=criteria)
    return {"k1": k1, "d1": d1, "k2": k2, "d2": d2, "rotation": rotation, "translation": translation}


def _adjacent_errors(board_xy: np.ndarray, cols: int, points: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """Relative length errors of the grid's adjacent corners (rows and columns), ``points`` (N, 3); a pair
    with a point not ``usable`` is left out."""
    index = np.arange(len(board_xy)).reshape(-1, cols)
    pairs = np.vstack([np.column_stack([index[:, :-1].ravel(), index[:, 1:].ravel()]),
                       np.column_stack([index[:-1].ravel(), index[1:].ravel()])])
    pairs = pairs[usable[pairs[:, 0]] & usable[pairs[:, 1]]]
    true = np.linalg.norm(board_xy[pairs[:, 0]] - board_xy[pairs[:, 1]], axis=1)
    found = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    return (found - true) / true


#: an undistorted point is usable when its distortion maps it back within this many pixels
UNDISTORTED_PX = 0.01


def _undistorted(pixels: np.ndarray, k: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normalised image coordinates (2, N) of ``pixels`` through OpenCV's iterative undistortion, and
    which of them are sound: mapped back to their pixel and inside the radius where OpenCV's radial
    distortion folds over (near a strongly distorted image's corners its iteration can fail or land on
    the wrong branch: those points are left out of OpenCV's figures, not held against it)."""
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    normalised = cv2.undistortPoints(pixels.reshape(-1, 1, 2), k, d, None, None, None, criteria).reshape(-1, 2)
    rays = np.column_stack([normalised, np.ones(len(normalised))])
    back, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), k, d)
    usable = np.linalg.norm(back.reshape(-1, 2) - pixels.reshape(-1, 2), axis=1) < UNDISTORTED_PX
    # beyond the radius where the radial distortion folds over, a pixel has two pre-images and the
    # iteration may land on the wrong one (it then maps back all the same)
    k1, k2, _, _, k3 = (list(np.ravel(d)) + [0.0] * 5)[:5]
    radii = np.linspace(0.0, 3.0, 3001)
    slope = 1 + 3 * k1 * radii ** 2 + 5 * k2 * radii ** 4 + 7 * k3 * radii ** 6
    fold = radii[np.argmax(slope <= 0)] if (slope <= 0).any() else np.inf
    usable &= np.linalg.norm(normalised, axis=1) < fold
    return normalised.T, usable


def _opencv_distances(calibration: dict, board_xy: np.ndarray, cols: int, views: list) -> tuple[np.ndarray, int]:
    """The held-out views' adjacent corners triangulated with OpenCV's calibration: relative errors, and
    how many corners were left out because OpenCV's undistortion did not invert there."""
    k1, d1, k2, d2 = (calibration[k] for k in ("k1", "d1", "k2", "d2"))
    p1 = np.hstack([np.eye(3), np.zeros((3, 1))])
    p2 = np.hstack([calibration["rotation"], calibration["translation"].reshape(3, 1)])
    errors, left_out = [], 0
    for left, right in views:
        a, usable_a = _undistorted(left, k1, d1)
        b, usable_b = _undistorted(right, k2, d2)
        usable = usable_a & usable_b
        left_out += int((~usable).sum())
        homogeneous = cv2.triangulatePoints(p1, p2, a, b)
        errors.append(_adjacent_errors(board_xy, cols, (homogeneous[:3] / homogeneous[3]).T, usable))
    return np.concatenate(errors), left_out


def _ours_relative(validation) -> float:
    """Our held-out adjacent distances' RMS relative error, pooled over the range bins."""
    bins = [b for b in validation.held_out.adjacent if b.count]
    return float(np.sqrt(sum(b.count * b.rms_relative ** 2 for b in bins) / sum(b.count for b in bins)))


def compare_set(folder: str | Path, seed: int = 0) -> dict:
    """The figures of one board set (module docstring) as a JSON-able dict."""
    folder = Path(folder)
    target = read_target(folder / "board.json")
    pattern = (target.cols, target.rows)
    _, board_xy = target.points()
    objects_one = np.column_stack([board_xy, np.zeros(len(board_xy))]).astype(np.float32)
    pairs = set_pairs(folder)
    labels = [left.stem for left, _ in pairs]
    opencv_found, ours_found, size = {}, {}, None
    for label, pair in zip(labels, pairs, strict=True):
        for side, path in zip(("left", "right"), pair, strict=True):
            grey = to_grey8(read_image(path))
            size = (grey.shape[1], grey.shape[0])
            opencv_found[(label, side)] = opencv_bare(grey, pattern)
            ours_found[(label, side)] = bool(target.detect(grey))
    both_opencv = [label for label in labels if all(opencv_found[(label, s)] is not None for s in ("left", "right"))]
    kept = detect_views(target, pairs, labels)
    ours_labels = [view.label for view in kept.views]

    def opencv_views(chosen):
        return ([objects_one] * len(chosen), [opencv_found[(label, "left")].astype(np.float32) for label in chosen],
                [opencv_found[(label, "right")].astype(np.float32) for label in chosen])

    opencv_all = _opencv_calibration(*opencv_views(both_opencv), size)
    options = CalibrationOptions(free=FREED)
    ours_all = calibrate_views(target, kept.views, "air", options=options).result.calibration.rig(0, frame="rig")
    ours_figures = {"f_l": ours_all.left.interior.f, "f_r": ours_all.right.interior.f,
                    "baseline": float(np.linalg.norm(ours_all.right.exterior.position))}
    opencv_figures = {"f_l": float(opencv_all["k1"][0, 0]), "f_r": float(opencv_all["k2"][0, 0]),
                      "baseline": float(np.linalg.norm(opencv_all["translation"]))}
    # the same views held out for both, among the pairs both find
    common = [label for label in ours_labels if label in set(both_opencv)]
    held = set(holdout_views(tuple(common), HOLDOUT_SHARE, seed))
    ours_views = [view for view in kept.views if view.label in set(common)]
    ours_order = [view.label for view in ours_views]
    validation = calibrate_views(target, ours_views, "air", holdout=HOLDOUT_SHARE, seed=seed,
                                 options=options).validation
    if set(validation.held_out.views) != held:
        raise RuntimeError(f"{folder.name}: the held-out views differ between ours and OpenCV's")
    fitted = [label for label in ours_order if label not in held]
    opencv_fit = _opencv_calibration(*opencv_views(fitted), size)
    opencv_held, left_out = _opencv_distances(opencv_fit, board_xy, target.cols,
                                    [(opencv_found[(label, "left")], opencv_found[(label, "right")])
                                     for label in ours_order if label in held])
    images = 2 * len(pairs)
    return {
        "set": folder.name, "pairs": len(pairs), "image_size": list(size),
        "images_found_opencv": sum(v is not None for v in opencv_found.values()),
        "images_found_ours": sum(ours_found.values()),
        "images_found_ours_where_opencv_finds": sum(ours_found[k] for k, v in opencv_found.items() if v is not None),
        "images": images, "pairs_found_opencv": len(both_opencv), "pairs_kept_ours": len(ours_labels),
        "set_aside_ours": [reason for _, reason in kept.set_aside],
        "ours": ours_figures, "opencv": opencv_figures,
        "relative_difference": {k: ours_figures[k] / opencv_figures[k] - 1 for k in ours_figures},
        "held_out_views": sorted(held),
        "held_out_rms_relative_ours": _ours_relative(validation),
        "held_out_rms_relative_opencv": float(np.sqrt(np.mean(opencv_held ** 2))),
        "held_out_corners_opencv_could_not_undistort": left_out,
    }


def sets_under(root: str | Path) -> Iterator[Path]:
    """The board sets (folders with ``board.json``) under ``root``."""
    for path in sorted(Path(root).iterdir()):
        if (path / "board.json").is_file():
            yield path
