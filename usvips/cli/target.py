"""``usvips target describe|print|detect``: describe a calibration target in a file, print a board at true
scale, find a target in images.

Sizes on the command line are in millimetres (``--square 24``); the file holds metres. The work is in
:mod:`usvips.core.calibration_targets` and :mod:`usvips.io.target_file`; this module parses and prints.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from usvips.core.calibration_targets import kind, names
from usvips.core.errors import InvalidParameterError
from usvips.io.atomic import replacing
from usvips.io.images import read_image
from usvips.io.target_file import read_target, write_printable, write_target

#: the largest length (mm) a describe option takes: a board of 10 m (the file's own limit)
MAX_TARGET_MM = 10_000
#: Command-line options of ``describe`` → (description field, converter). Lengths are given in mm.
OPTIONS = {
    "cols": ("cols", int), "rows": ("rows", int), "square": ("square", "mm"), "marker": ("marker", "mm"),
    "dictionary": ("dictionary", str), "legacy": ("legacy", bool), "spacing": ("spacing", "mm"),
    "diameter": ("diameter", "mm"), "asymmetric": ("asymmetric", bool), "separation": ("separation", "mm"),
    "first_id": ("first_id", int), "upright": ("upright", bool), "mark": ("mark", str), "size": ("size", "mm"),
}


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("target", help="calibration targets: describe, print, detect, find a 3-D "
                                   "field from a few clicks")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    describe = actions.add_parser("describe", help="write a target description file")
    describe.add_argument("kind", help=f"target kind: {', '.join(names())}")
    describe.add_argument("--out", required=True, help="target file to write (JSON)")
    describe.add_argument("--force", action="store_true",
                      help="replace --out even when it is an input or holds a USVIPS project or "
                           "calibration (the old file is kept as NAME.bak)")
    describe.add_argument("--cols", type=int, help="columns: inner corners (chessboard), squares (charuco), "
                          "markers (marker-grid), circles per row (circle-grid)")
    describe.add_argument("--rows", type=int, help="rows, counted as --cols")
    describe.add_argument("--square", type=float, metavar="MM", help="square size (mm)")
    describe.add_argument("--marker", type=float, metavar="MM", help="marker size (mm)")
    describe.add_argument("--dictionary", help="ArUco/AprilTag dictionary, e.g. 5X5_100, APRILTAG_36h11")
    describe.add_argument("--legacy", action="store_true", help="ChArUco: OpenCV's pattern before 4.6")
    describe.add_argument("--separation", type=float, metavar="MM", help="marker-grid: gap between markers (mm)")
    describe.add_argument("--first-id", dest="first_id", type=int, help="marker-grid: id of the first marker")
    describe.add_argument("--spacing", type=float, metavar="MM", help="circle-grid: centre spacing (mm)")
    describe.add_argument("--diameter", type=float, metavar="MM", help="circle-grid: circle diameter (mm)")
    describe.add_argument("--asymmetric", action="store_true", help="circle-grid: OpenCV's asymmetric pattern")
    describe.add_argument("--upright", action="store_true",
                          help="a symmetric board: corner 0 is the one from which the board runs rightwards "
                          "(the board is never turned beyond a quarter turn in the images)")
    describe.add_argument("--control", help="target-field: control file (id,X,Y,Z in metres)")
    describe.add_argument("--mark", choices=("cross", "disc"), help="target-field: what each target looks like")
    describe.add_argument("--size", type=float, metavar="MM", help="target-field: target diameter (mm)")
    describe.set_defaults(handler=run_describe, parameter_options={"points": "--control"})  # a field's points

    printable = actions.add_parser("print", help="write a printable PDF of a board at true scale")
    printable.add_argument("target", help="target file")
    printable.add_argument("--out", required=True, help="PDF to write")
    printable.add_argument("--force", action="store_true",
                       help="replace --out even when it is an input or holds a USVIPS project or "
                            "calibration (the old file is kept as NAME.bak)")
    printable.set_defaults(handler=run_print)

    detect = actions.add_parser("detect", help="find the target in images: points found and their quality")
    detect.add_argument("target", help="target file")
    detect.add_argument("images", nargs="+", metavar="IMAGE", help="images (grey or colour, 8 or 16 bits)")
    detect.set_defaults(handler=run_detect)


def description_from_args(args: argparse.Namespace) -> dict:
    """The description the options give (lengths converted from mm to metres); an option the kind does not
    take is an error naming it."""
    if args.kind not in names():
        raise InvalidParameterError("kind", f"unknown target kind {args.kind!r}; known: {', '.join(names())}")
    cls = kind(args.kind)
    description: dict = {"kind": args.kind}
    for option, (name, convert) in OPTIONS.items():
        value = getattr(args, option, None)
        if value is None or value is False:
            continue
        if convert == "mm" and not (math.isfinite(value) and 0 < value <= MAX_TARGET_MM):
            raise InvalidParameterError(option, f"must be a length in millimetres from 0 to "
                                        f"{MAX_TARGET_MM:g}, got {value:g}")
        description[name] = value * 1e-3 if convert == "mm" else value
    if args.kind == "target-field":
        if not args.control:
            raise InvalidParameterError("--control", "a target-field needs its control file (id,X,Y,Z in metres)")
        from usvips.io.tables import read_control

        control = read_control(args.control)
        description["points"] = [[pid, *map(float, row)] for pid, row in zip(control.ids, control.xyz, strict=True)]
        description.setdefault("mark", "cross")
    elif args.control:
        raise InvalidParameterError("--control", f"only a target-field takes a control file, not a {args.kind}")
    allowed = {"kind"} | _fields(cls)
    for name in description:
        if name not in allowed:
            option = "--" + next(o for o, (n, _) in OPTIONS.items() if n == name).replace("_", "-")
            raise InvalidParameterError(option, f"not an option of a {args.kind} target")
    return description


def _fields(cls) -> set[str]:
    """The description fields of a kind (read from the code of its constructor's signature)."""
    import inspect

    return set(inspect.signature(cls.__init__).parameters) - {"self", "source", "ids", "xyz"} | (
        {"points"} if cls.kind == "target-field" else set())


def _summary(target) -> str:
    points = target.control_points()
    described = ", ".join(f"{key} {value * 1000:g} mm" if isinstance(value, float) else f"{key} {value}"
                          for key, value in target.describe().items() if key not in ("kind", "points"))
    return f"{target.kind} ({described}): {len(points)} points"


def run_describe(args: argparse.Namespace) -> int:
    from usvips.core.calibration_targets import from_description

    target = from_description(description_from_args(args))
    with replacing(args.out, [args.control], replace=args.force):  # a target field's control file is a source
        write_target(args.out, target)
    print(f"wrote {args.out}: {_summary(target)}")
    return 0


def run_print(args: argparse.Namespace) -> int:
    target = read_target(args.target)
    with replacing(args.out, [args.target], replace=args.force):
        width, height = write_printable(args.out, target)
    print(f"wrote {args.out}: {_summary(target)} on a page of {width * 1000:.0f} × {height * 1000:.0f} mm; "
          "print at 100 % and measure the scale bar")
    return 0


def run_detect(args: argparse.Namespace) -> int:
    target = read_target(args.target)
    total = len(target.control_points())
    found = 0
    for path in args.images:
        image = read_image(path)
        detection = target.detect(image)
        if detection:
            found += 1
            shown = [note for note in detection.notes if not note.startswith("found by ")]
            notes = f" ({'; '.join(shown)})" if shown else ""
            by = f", found by {detection.stage}" if detection.stage else ""
            print(f"{path}: {len(detection)}/{total} points, mean quality {float(np.mean(detection.quality)):.1f}"
                  f"{by}{notes}")
        else:
            print(f"{path}: not found: {detection.reason}")
    print(f"found in {found} of {len(args.images)} images")
    return 0
