"""``usvips project add-pairs|add-video``: a user's own image pairs and stereo video into a project (the
work is in :mod:`usvips.app.video_project`).

The handlers import the work (numpy, SciPy, OpenCV, PyAV) when they run: ``usvips project --help``
registers these actions without it."""

from __future__ import annotations

import argparse


def register_project_actions(actions: argparse._SubParsersAction) -> None:
    """``project add-pairs`` and ``project add-video`` (called by :mod:`usvips.cli.project`)."""
    pairs = actions.add_parser("add-pairs", help="add image pairs from two folders or lists of files")
    pairs.add_argument("project")
    pairs.add_argument("--left", nargs="+", required=True, help="left images or a folder of them")
    pairs.add_argument("--right", nargs="+", required=True, help="right images or a folder of them")
    pairs.add_argument("--label-prefix", default="", help="put before every pair's label")
    pairs.add_argument("--pair-by", choices=("auto", "stem", "time", "order"), default="auto",
                       help="shared stem (IMG_0042_L ↔ IMG_0042_R), EXIF capture time, or name order; auto: stem "
                       "when every file has a partner, else capture time (JPEGs), else order")
    pairs.add_argument("--max-dt", type=float, default=1.0, help="seconds between partners' capture times (time)")
    pairs.add_argument("--medium", choices=("water", "air"), default="water")
    pairs.add_argument("--dry-run", action="store_true", help="print the pairing, store nothing")
    pairs.set_defaults(handler=run_add_pairs)
    video = actions.add_parser("add-video", help="add a stereo video (each camera one file or its chapters in order)")
    video.add_argument("project")
    video.add_argument("--left", nargs="+", required=True, help="the left camera's file(s), in recording order")
    video.add_argument("--right", nargs="+", required=True, help="the right camera's file(s), in recording order")
    video.add_argument("--label", help="the video pair's label (default: the left file's stem)")
    video.add_argument("--scan", action="store_true", help="decode every frame to find repeated pictures too")
    video.add_argument("--medium", choices=("water", "air"), default="water",
                       help="what the cameras looked through (default water; an in-air calibration video: air)")
    video.set_defaults(handler=run_add_video)


def run_add_pairs(args: argparse.Namespace) -> int:
    from usvips.app import video_project
    from usvips.io.pairing import RULE_NAMES
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    plan, rule = video_project.plan_image_pairs(args.left, args.right, args.label_prefix, args.pair_by, args.max_dt)
    print(f"{len(plan)} pairs by {RULE_NAMES[rule]}:")
    for label, left, right in plan:
        print(f"  {label}: {left} | {right}")
    if args.dry_run:
        return 0
    with open_project(args.project) as project:
        video_project.add_image_pairs(project, plan, args.medium)
    print(f"added {len(plan)} pairs to {shown(args.project)}")
    return 0


def run_add_video(args: argparse.Namespace) -> int:
    from usvips.app import video_project
    from usvips.store.opening import open_project

    with open_project(args.project) as project:
        added = video_project.add_video(project, args.left, args.right, args.label, args.scan, args.medium)
    print(f"added {added.summary}")
    for warning in added.warnings:
        print(f"  warning: {warning}")
    return 0
