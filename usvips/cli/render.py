"""``usvips render SCENE.json --out DIR``: render a sample project (images, control, observations, truth);
``usvips render --target T --housing KIND --out DIR``: board views through a housing, to rehearse a
calibration.

The work is :func:`usvips.app.render.render_scene` and :func:`usvips.app.board_render.render_board_views`;
this module parses the arguments and prints."""

from __future__ import annotations

import argparse
from pathlib import Path

from usvips.app.board_render import Rehearsal, parse_housing_values, render_board_views
from usvips.app.render import render_scene
from usvips.core import housing as housings
from usvips.core.errors import InvalidParameterError
from usvips.io.calibration_file import load_calibration


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("render", help="render a sample project from a scene description, or board "
                                   "views through a housing (--target) to rehearse a calibration")
    parser.add_argument("scene", nargs="?", help="scene description (JSON); or give --target")
    board = parser.add_argument_group("board views (--target): stills and a stereo video through a housing, with "
                                      "their truth (the same --seed gives the same views through every housing)")
    board.add_argument("--target", metavar="TARGET.json", help="the board to render (`usvips target describe`)")
    board.add_argument("--housing", default="air", choices=housings.names(),
                       help="the housing kind the cameras look through (default air)")
    board.add_argument("--housing-value", nargs="+", action="extend", default=[], metavar="NAME=VALUE",
                       help="a housing parameter for both cameras (e.g. g=0.05 t=0.01 n3=1.0 for an empty tank's "
                            "wall); the rest at the kind's defaults")
    board.add_argument("--calibration", help="take the cameras (interiors, relative orientation) from this "
                       "calibration file (default: f = 0.9 x width, 15 cm apart)")
    board.add_argument("--views", type=int, default=15, help="still image pairs (default 15)")
    board.add_argument("--video-frames", type=int, default=0, help="frames of a stereo video of the board moving "
                       "(default 0: none)")
    board.add_argument("--fps", type=int, default=10, help="the video's frames per second (default 10)")
    board.add_argument("--distance", nargs=2, type=float, default=[0.5, 1.0], metavar=("NEAR", "FAR"),
                       help="board distances in metres (default 0.5 1.0)")
    board.add_argument("--tilt", nargs=2, type=float, default=[15.0, 40.0], metavar=("LEAST", "MOST"),
                       help="board tilts in degrees (default 15 40)")
    board.add_argument("--image-size", default="1280x960", metavar="WxH", help="image size (default 1280x960)")
    board.add_argument("--supersample", type=int, default=3, help="samples per pixel side (default 3)")
    board.add_argument("--noise", type=float, default=1.0, help="image noise in grey levels (default 1)")
    board.add_argument("--seed", type=int, default=0, help="seed of the board poses and noise (default 0)")
    parser.add_argument("--out", required=True, help="output directory (created if needed)")
    parser.add_argument("--force", action="store_true", help="replace files of --out that hold a USVIPS calibration "
                        "or project, or the scene itself (each kept as NAME.bak)")
    parser.set_defaults(handler=run)


def _size(text: str) -> tuple[int, int]:
    width, sep, height = text.lower().partition("x")
    if not sep or not width.isdigit() or not height.isdigit():
        raise InvalidParameterError("--image-size", f"expected WIDTHxHEIGHT, got {text!r}")
    return int(width), int(height)


def run_board(args: argparse.Namespace) -> int:
    plan = Rehearsal(views=args.views, video_frames=args.video_frames, fps=args.fps,
                     distances=tuple(args.distance), tilts=tuple(args.tilt), size=_size(args.image_size),
                     supersample=args.supersample, noise=args.noise, seed=args.seed)
    names = {"views": "--views", "video_frames": "--video-frames",
             "distances": "--distance", "tilts": "--tilt", "size": "--image-size",
             "supersample": "--supersample", "noise": "--noise", "fps": "--fps", "seed": "--seed"}
    try:
        plan.check()
    except InvalidParameterError as error:
        raise InvalidParameterError(names.get(error.parameter, error.parameter), error.problem) from None
    calibration = load_calibration(args.calibration) if args.calibration else None
    try:
        values = parse_housing_values(args.housing_value)
    except InvalidParameterError as error:
        raise InvalidParameterError("--housing-value", error.problem) from None
    truth = render_board_views(args.target, args.out, args.housing, values, plan, calibration, replace=args.force)
    print(f"rendered {len(truth['views'])} view pairs"
          + (f" and a stereo video of {plan.video_frames} frames" if plan.video_frames else "")
          + f" of {args.target} through {args.housing} into {Path(args.out)} (truth in truth.json)")
    return 0


def run(args: argparse.Namespace) -> int:
    if args.target and args.scene:
        raise InvalidParameterError("--target", "give a scene or --target, not both")
    if args.target:
        return run_board(args)
    if not args.scene:
        raise InvalidParameterError("scene", "give a scene description (JSON) or --target with a board to render")
    scene = render_scene(args.scene, args.out, replace=args.force)
    print(f"rendered {len(scene.data['pairs'])} pairs of {scene.name} into {Path(args.out)}")
    return 0
