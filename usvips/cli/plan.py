"""``usvips plan``: the expected sigma of a point and of a length over the field of view and range, for a
calibration or for a rig on paper (``usvips/core/planner.py``)."""

from __future__ import annotations

import argparse
import json

import numpy as np

from usvips.core import housing as housings
from usvips.core import validation
from usvips.core.errors import InvalidParameterError
from usvips.core.plain_numbers import plain_number
from usvips.core.planner import default_grid, planned_rig, precision_map
from usvips.io.atomic import replacing
from usvips.io.calibration_file import load_calibration
from usvips.io.opencv_calibration import parse_image_size


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("plan", help="map the expected sigma of a point and a length (precision planner)")
    parser.add_argument("--calibration", help="a calibration file (JSON); or describe a rig with the options below")
    rig = parser.add_argument_group("a rig on paper (instead of --calibration)")
    rig.add_argument("--focal-px", type=float, help="principal distance (pixels)")
    rig.add_argument("--image-size", metavar="WxH", help="image size (pixels)")
    rig.add_argument("--baseline", type=float, help="distance between the perspective centres (m)")
    rig.add_argument("--toe-in", type=float, default=0.0, help="each camera turned inward by this (degrees)")
    rig.add_argument("--housing", choices=housings.names(), default="air",
                     help="the housing of each camera, square to its optical axis (values by --port); "
                          + "; ".join(f"{k.kind}: {k.description}" for k in housings.registered_kinds()))
    rig.add_argument("--port", action="append", default=[], metavar="NAME=VALUE",
                     help="the housing's values (the kind's parameters, e.g. g, t, n2, n3 of a flat port; "
                          "metres); the others take the calibration's defaults")
    rig.add_argument("--sigma-px", type=float, default=0.3, help="pointing precision (pixels, default 0.3)")
    parser.add_argument("--length", type=float, default=0.3, help="the length to plan for (m, default 0.3)")
    parser.add_argument("--range", dest="ranges", metavar="NEAR:FAR[:N]", help="ranges (m; default: the common view)")
    parser.add_argument("--across", metavar="LEFT:RIGHT[:N]", help="positions along the baseline (m)")
    parser.add_argument("--height", type=float, default=0.0, help="height above the baseline (m)")
    parser.add_argument("--orientations", default=12, help="directions of the length (default 12)")
    parser.add_argument("--pointing-only", action="store_true", help="leave out the calibration's own uncertainty")
    parser.add_argument("--out", help="the map as a picture (.png, .pdf, .svg)")
    parser.add_argument("--json", action="store_true", help="print the figures per range as JSON")
    parser.add_argument("--force", action="store_true", help="replace --out even when it is the --calibration or "
                        "holds a USVIPS calibration or project (the old file is kept as NAME.bak)")
    parser.set_defaults(handler=run)


#: the most positions along one axis of the map (ranges, or positions across), and directions of the length
MAX_GRID = 500
MAX_ORIENTATIONS = 1000


#: the largest principal distance (px) planned for: a 1000 mm lens on 1 µm pixels
MAX_FOCAL_PX = 1e6


def _span(option: str, text: str, count: int, positive: bool = False) -> np.ndarray:
    parts = text.split(":")
    try:
        values = [float(p) for p in parts[:2]]
    except ValueError:
        values = []
    if len(parts) not in (2, 3) or len(values) != 2 or not np.all(np.isfinite(values)):
        raise InvalidParameterError(option, f"expected FROM:TO[:COUNT] in metres, got {text!r}")
    n = validation.count(f"{option} COUNT", parts[2], 1, MAX_GRID) if len(parts) == 3 else count
    if not (values[0] < values[1] or values[0] == values[1] and n == 1):
        raise InvalidParameterError(option, f"FROM must be less than TO (or equal with a COUNT of 1), got {text!r}")
    if positive and values[0] <= 0:
        raise InvalidParameterError(option, f"ranges are distances in front of the rig: FROM must be > 0 m, "
                                    f"got {text!r}")
    return np.linspace(values[0], values[1], n)


def _check_numbers(args: argparse.Namespace) -> None:
    """Every number option finite and in its range, named (``--height nan`` is the height's fault)."""
    for option, value, low in (("--focal-px", args.focal_px, 0.0), ("--baseline", args.baseline, 0.0),
                               ("--sigma-px", args.sigma_px, 0.0), ("--length", args.length, 0.0),
                               ("--height", args.height, None), ("--toe-in", args.toe_in, None)):
        if value is None:
            continue
        number = validation.finite(option, value)
        if low is not None and number <= low:
            raise InvalidParameterError(option, f"must be > {low:g}, got {number:g}")
    if args.focal_px is not None and not 1.0 <= args.focal_px <= MAX_FOCAL_PX:
        raise InvalidParameterError("--focal-px", f"must be 1 to {MAX_FOCAL_PX:g} pixels (a camera's principal "
                                    f"distance), got {args.focal_px:g}")
    if abs(args.toe_in) >= 90:
        raise InvalidParameterError("--toe-in", f"must be less than 90 degrees either way, got {args.toe_in:g}")
    args.orientations = validation.count("--orientations", args.orientations, 1, MAX_ORIENTATIONS)


def _rig(args: argparse.Namespace):
    if args.calibration:
        return load_calibration(args.calibration), args.calibration
    missing = [o for o, v in (("--focal-px", args.focal_px), ("--image-size", args.image_size),
                              ("--baseline", args.baseline)) if v is None]
    if missing:
        raise InvalidParameterError("--calibration", f"give a calibration, or a rig with {', '.join(missing)}")
    width, height = parse_image_size(args.image_size)
    kind = housings.kind(args.housing)
    values: dict[str, float] = {}
    for item in args.port:
        name, _, value = item.partition("=")
        if name not in kind.priors():
            raise InvalidParameterError("--port", f"unknown {name!r}; the {kind.kind} housing takes "
                                        f"{', '.join(kind.priors()) or 'no values'} as NAME=VALUE")
        try:
            values[name] = float(plain_number(value))
        except ValueError:
            raise InvalidParameterError("--port", f"{item!r}: {value!r} is not a number") from None
    housing = kind.from_symbols(values)
    label = (f"f {args.focal_px:g} px, {width}x{height}, baseline {args.baseline:g} m, toe-in {args.toe_in:g}°, "
             f"{args.housing}")
    return planned_rig(args.focal_px, width, height, args.baseline, np.radians(args.toe_in), housing,
                       args.sigma_px), label


def run(args: argparse.Namespace) -> int:
    if not args.out and not args.json:
        raise InvalidParameterError("--out", "give --out PICTURE and/or --json")
    with replacing([args.out] if args.out else [], [args.calibration], replace=args.force):
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    _check_numbers(args)
    calibration, label = _rig(args)
    across, ranges = default_grid(calibration)
    if args.ranges:
        ranges = _span("--range", args.ranges, 10, positive=True)
    if args.across:
        across = _span("--across", args.across, 15)
    plan = precision_map(calibration, across, ranges, args.length, args.height, args.orientations,
                         include_calibration=not args.pointing_only)
    if args.out:
        from usvips.io.plan_figure import write_plan_figure  # deferred: matplotlib takes ~0.5 s to import

        write_plan_figure(plan, args.out, label)
    if args.json:
        print(json.dumps(plan.summary(), indent=2))
    else:
        for row in plan.summary()["ranges"]:
            figure = row["length_sigma_rms_m"]
            text = f"{figure[0] * 1e3:.2f}..{figure[1] * 1e3:.2f} mm" if figure else "- (no end pair in view)"
            print(f"range {row['range_m']:.2f} m: {args.length:g} m length sigma {text} "
                  f"({row['positions_seen']} of {len(plan.across)} positions seen)")
        print(f"wrote {args.out}")
    return 0
