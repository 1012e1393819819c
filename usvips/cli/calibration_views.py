"""``usvips video calibration-views``: choose the views of a calibration target from a project's stereo
video and write them as observations (``id,xl,yl,xr,yr,pair``), with the coverage and advice.

Registered as an action of ``usvips video`` (this module is listed after ``video`` in
:data:`usvips.cli.COMMANDS`)."""

from __future__ import annotations

import argparse
import sys

from usvips.app import calibration_video
from usvips.core.calibration_views import MAX_EDGE_WIDTH_PX
from usvips.io.atomic import replacing
from usvips.store.opening import open_project


def _video_actions(subparsers: argparse._SubParsersAction) -> argparse._SubParsersAction:
    """The sub-actions of ``usvips video`` (registered before this module)."""
    video = subparsers.choices["video"]
    return next(a for a in video._actions if isinstance(a, argparse._SubParsersAction))


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = _video_actions(subparsers).add_parser(
        "calibration-views", help="find a calibration target in a stereo video, choose diverse sharp views and "
                                  "write them as observations (id,xl,yl,xr,yr,pair)")
    parser.add_argument("project", help="the project file")
    parser.add_argument("--pair", required=True, help="the stereo video's label")
    parser.add_argument("--target", required=True, help="the target's description file (JSON)")
    parser.add_argument("--every", type=int, default=5, help="look at every K-th instant (default 5)")
    parser.add_argument("--max-views", type=int, default=calibration_video.DEFAULT_MAX_VIEWS,
                        help=f"at most N views (default {calibration_video.DEFAULT_MAX_VIEWS})")
    parser.add_argument("--max-blur", type=float, default=MAX_EDGE_WIDTH_PX,
                        help=f"edge width (px) beyond which an instant is blurred when its edges are also wider than "
                             f"half the spacing of the target's points (default {MAX_EDGE_WIDTH_PX:g}; a sharp edge is "
                             "about 2)")
    parser.add_argument("--focal", type=float, default=None,
                        help="focal length (px) for the tilts (default: the image's larger side)")
    parser.add_argument("--out", required=True, help="observations CSV to write")
    parser.add_argument("--force", action="store_true", help="replace --out even when it is an input or holds a "
                        "USVIPS project or calibration (the old file is kept as NAME.bak)")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    # the library names a value in the user's words; the command line says which option to change
    parser.set_defaults(handler=run, parameter_options={"maximum views": "--max-views", "every": "--every",
                                                        "largest edge width": "--max-blur", "focal_px": "--focal",
                                                        "focal length": "--focal"})


def run(args: argparse.Namespace) -> int:
    shown = [-1]

    def progress(fraction: float, message: str) -> None:
        step = int(fraction * 10)
        if not args.quiet and step > shown[0]:
            shown[0] = step
            print(f"{100 * fraction:3.0f} % {message}", file=sys.stderr)

    target = calibration_video.read_target(args.target)  # a bad target file is named before the project is opened
    from usvips.app.project_contents import media_files

    with open_project(args.project, read_only=True) as project, \
            replacing(args.out, [args.target, *media_files(project)], args.project, replace=args.force):
        result = calibration_video.views_from_video(project, args.pair, target, args.out, args.every,
                                                     args.max_views, args.max_blur, args.focal, progress)
    for line in result.summary():
        print(line)
    rows = sum(len(v.common_ids()) for v in result.views)
    print(f"wrote {args.out}: {len(result.views)} views, {rows} observations")
    return 0
