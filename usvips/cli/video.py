"""``usvips video sync|set-offset|export-frame|take-pair|proxy|period``: a user's stereo video from the
command line (the work is in :mod:`usvips.app.video_project`; ``usvips project add-pairs|add-video`` are
in :mod:`usvips.cli.project_media`)."""

from __future__ import annotations

import argparse
import json

from usvips.app import video_project
from usvips.core import validation
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.store.opening import open_project


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("video", help="synchronise a stereo video, set its offset, export a frame pair")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    sync = actions.add_parser("sync", help="estimate the left/right frame offset and store it")
    sync.add_argument("project")
    sync.add_argument("--pair", required=True, help="the video pair's label")
    sync.add_argument("--method", choices=("flash", "audio", "image"),
                      help="default: audio when both files have sound, else a clear flash, else the images")
    sync.add_argument("--max-offset", help="frames searched either way (default: a third of the video, at most "
                      "300; at least half a second's frames); an offset found at the window's edge is not stored")
    sync.add_argument("--calibration", type=int, help="calibration id for --method image (default: the one "
                      "active for the video, else the latest)")
    sync.add_argument("--json", action="store_true", help="print the estimate as JSON")
    sync.add_argument("--dry-run", action="store_true", help="print the estimate, store nothing")
    sync.add_argument("--force", action="store_true",
                      help=f"store the estimate even when its confidence is below {video_project.STORE_CONFIDENCE} "
                      "(never one at the edge of its search window)")
    sync.set_defaults(handler=run_sync)
    offset = actions.add_parser("set-offset", help="set the offset by hand: left frame i ↔ right frame i + FRAMES")
    offset.add_argument("project")
    offset.add_argument("--pair", required=True)
    offset.add_argument("frames", type=int)
    offset.set_defaults(handler=run_set_offset)
    export = actions.add_parser("export-frame", help="write DIR/left.png (left frame N) and DIR/right.png "
                                "(right frame N + offset), exactly as decoded")
    export.add_argument("project")
    export.add_argument("--pair", required=True)
    export.add_argument("--frame", type=int, required=True)
    export.add_argument("--out", required=True, help="the folder to write into (created if needed)")
    export.set_defaults(handler=run_export_frame)
    take = actions.add_parser("take-pair", help="make a synchronised frame pair an image pair of the project "
                              "(e.g. the calibration frame filmed in air or underwater)")
    take.add_argument("project")
    take.add_argument("--pair", required=True, help="the video pair")
    take.add_argument("--frame", type=int, required=True, help="the left frame")
    take.add_argument("--label", help="the new image pair's label (default VIDEO-FRAME)")
    take.add_argument("--medium", choices=("water", "air"), default="water")
    take.set_defaults(handler=run_take_pair)
    proxy = actions.add_parser("proxy", help="build lossless all-intra seek proxies of a video pair (proxies/ beside "
                               "the project): random seeks decode one frame, pixels identical")
    proxy.add_argument("project")
    proxy.add_argument("--pair", required=True, help="the video pair")
    proxy.add_argument("--delete", action="store_true", help="delete the pair's seek proxies (seeks then decode "
                       "the original again: exact, slower)")
    proxy.set_defaults(handler=run_proxy)
    period = actions.add_parser("period", help="mark a named period (left frames START to END) of a video pair, "
                                "or list them")
    period.add_argument("project")
    period.add_argument("--pair", required=True)
    period.add_argument("--add", nargs=3, metavar=("NAME", "START", "END"),
                        help="mark a period from left frame START to END (inclusive)")
    period.set_defaults(handler=run_period)


def run_sync(args: argparse.Namespace) -> int:
    if args.dry_run and args.force:
        raise UsvipsError("--dry-run stores nothing and --force stores whatever the confidence: give one of them")
    if args.calibration is not None and args.method in ("flash", "audio"):
        raise UsvipsError(f"--calibration is used by --method image only; leave it out with --method {args.method}")
    with open_project(args.project) as project:
        estimate = video_project.estimate_offset(project, args.pair, args.method, args.max_offset, args.calibration)
        doubt = video_project.store_refusal(estimate, args.force)
        store = not args.dry_run and doubt is None
        if store:
            project.set_video_offset(args.pair, estimate.frames, estimate.as_dict())
    remedy = ("search a wider window (--max-offset), or set the offset with `usvips video set-offset`"
              if estimate.at_edge
              else "look at the pair in the window, set the offset with `usvips video set-offset`, or store this "
              "one with --force")
    kept = f"not stored: {doubt} ({remedy})" if doubt and not args.dry_run else ""
    if args.json:
        print(json.dumps({**estimate.as_dict(), "stored": store, **({"not_stored": kept} if kept else {})}))
        return 0
    print(estimate.summary() + ("; stored" if store else f"; {kept}" if kept else ""))
    return 0


def run_set_offset(args: argparse.Namespace) -> int:
    with open_project(args.project) as project:
        project.set_video_offset(args.pair, args.frames, {"method": "by hand"})
    print(f"video {args.pair!r}: left frame i shows the instant of right frame i {args.frames:+d}")
    return 0


def run_export_frame(args: argparse.Namespace) -> int:
    if not str(args.out).strip():
        raise InvalidParameterError("--out", "must name a folder (empty)")
    with open_project(args.project) as project:
        video = project.video(args.pair)
        left, right = video_project.export_frame(project, args.pair, args.frame, args.out)
    print(f"wrote {left} (left frame {args.frame}) and {right} (right frame {args.frame + video.offset_frames})")
    return 0


def run_period(args: argparse.Namespace) -> int:
    with open_project(args.project) as project:
        if args.add:
            name, start, end = args.add
            name = validation.name("--add NAME", name)
            try:
                start, end = int(start), int(end)
            except ValueError:
                raise UsvipsError(f"--add {name} {start} {end}: START and END must be frame numbers") from None
            if any(name == taken for taken, _, _ in project.periods(args.pair)):
                raise InvalidParameterError("--add NAME", f"video {args.pair!r} already has a period {name!r}: "
                                            "choose another name")
            project.add_period(args.pair, name, start, end)
        for name, start, end in project.periods(args.pair):
            print(f"{name}: frames {start} to {end}")
    return 0


def run_take_pair(args: argparse.Namespace) -> int:
    with open_project(args.project) as project:
        label = video_project.take_pair(project, args.pair, args.frame, args.label, args.medium)
    print(f"added image pair {label!r} (left frame {args.frame} of {args.pair} and its partner)")
    return 0


def run_proxy(args: argparse.Namespace) -> int:
    with open_project(args.project, read_only=True) as project:
        if args.delete:
            freed = video_project.delete_proxies(project, args.pair)
            print(f"video {args.pair!r}: " + (f"deleted its seek proxies ({freed / 2**20:.1f} MiB freed)" if freed
                                              else "it has no seek proxies"))
            return 0
        states = video_project.proxy_states(project, args.pair)
        plan = video_project.plan_proxies(project, args.pair, states)
    for _, state in states:
        if state.state == "stale":
            print(f"{state.path.name}: stale ({state.reason}); rebuilding")
    if not plan:
        print(f"video {args.pair!r}: its seek proxies are already built "
              f"({sum(state.bytes for _, state in states) / 2**20:.1f} MiB)")
        return 0
    for path in video_project.build_proxies(plan):
        print(f"wrote {path} ({path.stat().st_size / 2**20:.1f} MiB)")
    return 0
