"""``usvips detect PROJECT (--pair LABEL | --video LABEL [--every K] [--frames A:B]) [--model M]``: a
detection model's proposals on an image pair or a video's frames, paired through the housing, refined
along the refractive epipolar curve and stored as unreviewed objects whose source is the model (its name
and file hash recorded); one line per proposal, then a summary (usvips/app/detection_service.py). A
proposal never overwrites a person's object: one that repeats a stored object is reported, not stored.
On a video, the proposals of one fish on successive frames are joined as instants of one object
(``--max-speed``: the fastest a fish is taken to swim, m/s). Without ``--model``, the project's default model
(``--model M --remember`` makes M the default), else the model shipped in resources/models/ (when exactly
one is).
``usvips detect PROJECT --review-sigma [--model M]`` measures the model's keypoint pointing sigma from the
reviewers' corrections of its accepted proposals and prints the description file's [keypoint_sigma] table;
``usvips detect PROJECT --max-n`` prints MaxN per species on each video and pair from accepted objects."""

from __future__ import annotations

import argparse

from usvips.cli import whole_number
from usvips.cli.common import add_annotator_option, positive_number, whole_number_from


def frame_range(text: str) -> tuple[int, int]:
    """``A:B``: left frames A to B, both included (whole numbers, 0 ≤ A ≤ B)."""
    first, colon, last = text.partition(":")
    try:
        if not colon:
            raise ValueError
        a, b = whole_number(first), whole_number(last)
    except (ValueError, argparse.ArgumentTypeError):
        raise argparse.ArgumentTypeError(f"{text!r} is not a frame range A:B (two whole numbers of at most "
                                         "2**63 - 1)") from None
    if a < 0 or b < a:
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 <= A <= B")
    return a, b


def add_model_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--model", metavar="DESCRIPTION", help="the model's description file (.toml or .json, "
                        "naming its ONNX file; docs/detection.md); default: the project's default model, else "
                        "the model shipped with USVIPS")


_speed = positive_number("a speed in m/s", "a speed > 0 m/s")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("detect", help="propose fish with a detection model: paired through the "
                                                  "housing, stored as unreviewed objects")
    parser.add_argument("project", help="project file (*.usvips) or survey (postgresql://…)")
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--pair", metavar="LABEL", help="an image pair of the project")
    where.add_argument("--video", metavar="LABEL", help="a stereo video of the project")
    where.add_argument("--review-sigma", action="store_true", help="detect nothing: measure the model's keypoint "
                       "pointing sigma from the reviewers' corrections of its accepted proposals, and print the "
                       "[keypoint_sigma] table for its description file")
    where.add_argument("--max-n", action="store_true", help="detect nothing: print MaxN per species on each video "
                       "and pair from the accepted objects")
    parser.add_argument("--every", type=whole_number_from(1), default=1, metavar="K",
                        help="every K-th left frame (video)")
    parser.add_argument("--frames", type=frame_range, metavar="A:B", help="left frames A to B, both included "
                        "(video; default: all)")
    add_model_option(parser)
    parser.add_argument("--remember", action="store_true", help="make --model the project's default detection "
                        "model (used when --model is not given, here and in the window)")
    parser.add_argument("--max-speed", type=_speed, default=None, metavar="M/S", help="video: the fastest a fish "
                        "is taken to swim when its proposals on successive frames are joined as instants of one "
                        "object (default 1.5)")
    parser.add_argument("--no-refine", action="store_true", help="keep the model's right keypoints (do not "
                        "refine them along the epipolar curve)")
    add_annotator_option(parser)
    parser.set_defaults(handler=run)


def load(given: str | None, project=None):
    """The model ``given`` (a description file), else the project's default, else the shipped one."""
    from usvips.app.detection_model import load_model, model_path_for

    return load_model(model_path_for(project, given))


def print_max_n(args: argparse.Namespace) -> int:
    from usvips.app.reviewed_max_n import reviewed_max_n
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    with open_project(args.project, read_only=True) as project:
        found = reviewed_max_n(project)
    for row in found:
        print(row.line())
    print(f"{shown(args.project)}: MaxN of {len({r.species for r in found})} species from accepted objects")
    return 0


def review_sigma(args: argparse.Namespace) -> int:
    from datetime import date

    from usvips.app.detection_review import description_table, sigma_from_reviews
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    model = load(args.model) if args.model is not None else None
    with open_project(args.project, read_only=True) as project:
        model = model or load(None, project)
        measured = sigma_from_reviews(project, model, date=date.today().isoformat())
    for value in measured.values():
        print(f"{model.tag}: {value.text}")
    print(description_table(measured, f"reviewers' corrections in {shown(args.project)}, {date.today().isoformat()}"),
          end="")
    return 0


def run(args: argparse.Namespace) -> int:
    from usvips.app.detection_service import detect_in_project
    from usvips.core.errors import InvalidParameterError
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    if args.remember and (args.model is None or args.pair is None and args.video is None):
        raise InvalidParameterError("--remember", "needs --model and --pair or --video: it makes the model "
                                    "detected with the project's default")
    if args.max_speed is not None and args.video is None:
        raise InvalidParameterError("--max-speed", "joins proposals over a video's frames: give --video")
    if args.review_sigma:
        return review_sigma(args)
    if args.max_n:
        return print_max_n(args)
    if args.pair is not None and (args.frames is not None or args.every != 1):
        raise InvalidParameterError("--frames" if args.frames is not None else "--every",
                                    "frames are chosen on a video, not on an image pair")
    from usvips.app.detection_model import remember_model
    from usvips.core.detection.association import DEFAULT_MAX_SPEED_M_S

    model = load(args.model) if args.model is not None else None  # a bad model is refused before opening
    with open_project(args.project) as project:
        model = model or load(None, project)
        run = detect_in_project(project, model, args.pair, args.video, args.every, args.frames,
                                refine=not args.no_refine, max_speed_m_s=args.max_speed or DEFAULT_MAX_SPEED_M_S)
        if args.remember:
            kept = remember_model(project, args.model)
    for proposal in run.proposals:
        print(proposal.line())
    print(f"{shown(args.project)}: " + "\n".join(run.summary()))
    if args.remember:
        print(f"{shown(args.project)}: default detection model is now {kept}")
    return 0
