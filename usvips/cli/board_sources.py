"""Where ``usvips calibrate air|water --target TARGET`` finds its views when no ``--obs`` file is given:
image pairs (``--images L1 R1 [L2 R2 …]``, or ``--left-images GLOB --right-images GLOB`` paired in name
order) or a project's stereo video (``--project P --video LABEL [--every K --max-views N]``). The target is
detected in each (:mod:`usvips.app.board_calibration`), the counts, each pair set aside and the coverage
advice are printed, and the calibration runs on the views found."""

from __future__ import annotations

import argparse
import glob
import re
from pathlib import Path

from usvips.app import board_calibration as boards
from usvips.app.calibration_video import DEFAULT_MAX_VIEWS
from usvips.cli.common import whole_number_from
from usvips.core.calibration import CalibrationOptions
from usvips.core.errors import InvalidParameterError
from usvips.core.stereo_calibration import StereoCalibration
from usvips.store.opening import open_project


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The view sources (each needs ``--target``; exclusive with ``--obs``)."""
    parser.add_argument("--images", nargs="+", metavar="IMAGE",
                        help="with --target: image pairs LEFT1 RIGHT1 [LEFT2 RIGHT2 …] in which the target is found")
    parser.add_argument("--left-images", metavar="GLOB",
                        help="with --target and --right-images: the left images (a pattern, e.g. 'cal/L*.png'), "
                             "paired with the right ones in name order")
    parser.add_argument("--right-images", metavar="GLOB", help="the right images (see --left-images)")
    parser.add_argument("--project", metavar="PROJECT", help="with --video: the project holding the video")
    parser.add_argument("--video", metavar="LABEL",
                        help="with --target and --project: find the views in the project's stereo video LABEL")
    parser.add_argument("--every", type=whole_number_from(1), default=5, metavar="K",
                        help="with --video: look at every K-th instant (default 5)")
    parser.add_argument("--max-views", type=whole_number_from(1), default=DEFAULT_MAX_VIEWS, metavar="N",
                        help=f"with --video: keep at most N diverse views (default {DEFAULT_MAX_VIEWS})")
    parser.set_defaults(parameter_options={"maximum views": "--max-views", "every": "--every"})


def _natural(path: str) -> tuple:
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in re.split(r"(\d+)", Path(path).name) if p)


def image_pairs(args: argparse.Namespace) -> list[tuple[str, str]]:
    """The (left, right) image pairs from ``--images`` or ``--left-images``/``--right-images``."""
    if args.images:
        if len(args.images) % 2:
            raise InvalidParameterError("--images", f"{len(args.images)} images given; give them in pairs: LEFT1 "
                                        "RIGHT1 LEFT2 RIGHT2 …")
        return list(zip(args.images[0::2], args.images[1::2], strict=True))
    if not (args.left_images and args.right_images):
        missing = "--right-images" if args.left_images else "--left-images"
        raise InvalidParameterError(missing, "the left and the right images are given together")
    sides = {}
    for option, pattern in (("--left-images", args.left_images), ("--right-images", args.right_images)):
        found = sorted(glob.glob(pattern), key=_natural)
        if not found:
            raise InvalidParameterError(option, f"no file matches {pattern!r}")
        sides[option] = found
    left, right = sides["--left-images"], sides["--right-images"]
    if len(left) != len(right):
        raise InvalidParameterError("--left-images/--right-images", f"{len(left)} left and {len(right)} right images "
                                    "match; each left image needs its right partner")
    return list(zip(left, right, strict=True))


def inputs(args: argparse.Namespace) -> list[str]:
    """Every file the views come from (the images, globs expanded; the project), for the check that no
    output is written over one of them."""
    found: list[str] = []
    if args.images or args.left_images or args.right_images:
        try:
            found += [path for pair in image_pairs(args) for path in pair]
        except InvalidParameterError:
            pass  # the images' own error is reported where they are read
    return found + ([args.project] if getattr(args, "project", None) else [])


def wants_views(args: argparse.Namespace) -> bool:
    """Whether the views come from images or a video (not from ``--obs``), checking the combination."""
    given = [name for name, value in (("--images", args.images), ("--left-images", args.left_images),
                                      ("--right-images", args.right_images), ("--video", args.video)) if value]
    if args.obs and given:
        raise InvalidParameterError(given[0], "give the observations either as --obs or as images/a video, not both")
    if not args.obs and not given:
        raise InvalidParameterError("--obs", "give the observations (--obs FILE), or --target with --images, "
                                    "--left-images/--right-images or --project/--video")
    if not given:
        return False
    if not args.target:
        raise InvalidParameterError(given[0], "finding the views needs the target: add --target TARGET.json")
    if args.video and (args.images or args.left_images or args.right_images):
        raise InvalidParameterError("--video", "give either images or a video, not both")
    if args.video and not args.project:
        raise InvalidParameterError("--video", "needs the project holding it: add --project PROJECT")
    return True


def find_views(args: argparse.Namespace) -> tuple[boards.BoardViews, dict]:
    """Detect the target in the images or the video, print what was found, and return the views and the
    calibration's source record."""
    target = boards.as_target(args.target)
    if args.video:
        with open_project(args.project, read_only=True) as project:
            found = boards.views_from_video(project, args.video, target, args.every, args.max_views)
        source = {"target": str(args.target), "project": str(args.project), "video": args.video,
                  "every": args.every, "max_views": args.max_views}
    else:
        pairs = image_pairs(args)
        found = boards.views_from_images(target, pairs)
        source = {"target": str(args.target), "images": [p for pair in pairs for p in pair]}
    for line in found.lines():
        print(line)
    return found, source


def calibrate(args: argparse.Namespace, phase: str, options: CalibrationOptions,
              base: StereoCalibration | None = None, housing: str | None = None) -> boards.BoardCalibration:
    """Find the views (:func:`find_views`) and calibrate from them (``--holdout``/``--seed`` honoured)."""
    found, source = find_views(args)
    if base is not None:
        source["base"] = str(args.base)
    return boards.calibrate_views(args.target, found.views, phase, base=base, housing=housing,
                                  holdout=args.holdout, seed=args.seed, options=options, source=source)
