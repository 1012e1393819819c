"""``usvips intersect``: 3-D points with sigmas from conjugate pixels and a calibration.

The sigmas combine the picks' pointing precision (``--pointing-sigma PX``, pixels per image coordinate;
without it the hand-click default of ``usvips.core.pointing`` — never the calibration's sigma0, which is
that of its own corners or targets) and the calibration's own uncertainty (its parameter covariance,
propagated to every point). The file is read, intersected and written in chunks
(:mod:`usvips.app.intersect_file`)."""

from __future__ import annotations

import argparse

from usvips.app.intersect_file import FailedPointsError, IntersectOptions, intersect_file
from usvips.cli.common import add_pointing_option
from usvips.core.errors import DegenerateGeometryError
from usvips.core.intersection import MISFIT_SIGNIFICANCE
from usvips.core.measurements import calibration_marks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX
from usvips.io.atomic import replacing
from usvips.io.calibration_file import load_calibration


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("intersect", help="intersect conjugate pixels: id,X,Y,Z,sX,sY,sZ (metres)")
    parser.add_argument("--calibration", required=True, help="calibration file (JSON)")
    parser.add_argument("--obs", required=True, help="observations CSV: id,xl,yl,xr,yr (pixels)")
    parser.add_argument("--out", required=True, help="points CSV to write")
    parser.add_argument("--station", default=None,
                        help="calibrated station (index or pair label) whose object frame to use (default: each "
                        "row at the station its pair column names; without a pair column, the first)")
    parser.add_argument("--frame", choices=["object", "rig"], default="object",
                        help="object: the control frame at the station; rig: left perspective centre, left axes")
    parser.add_argument("--pointing-only", action="store_true",
                        help="sigmas from the pointing precision alone, without the calibration's own uncertainty")
    parser.add_argument("--skip-failed", action="store_true",
                        help="write the points that intersect and list the others, instead of stopping")
    add_pointing_option(parser)
    parser.add_argument("--force", action="store_true", help="replace --out even when it is an input or holds a "
                        "USVIPS calibration or project (the old file is kept as NAME.bak)")
    parser.set_defaults(handler=run)


def options(args: argparse.Namespace) -> IntersectOptions:
    """The run's options from the command line."""
    station = None if args.station is None else int(args.station) if args.station.isdigit() else args.station
    return IntersectOptions(station=station, frame=args.frame,
                            include_calibration=not args.pointing_only, skip_failed=args.skip_failed,
                            pointing_sigma_px=HAND_CLICK_SIGMA_PX if args.pointing_sigma is None
                            else args.pointing_sigma)


def run(args: argparse.Namespace) -> int:
    with replacing(args.out, [args.calibration, args.obs], replace=args.force):
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    calibration = load_calibration(args.calibration)
    try:
        summary = intersect_file(calibration, args.obs, args.out, options(args))
    except FailedPointsError as error:
        where = f", line {error.line}" if error.line is not None else ""
        raise DegenerateGeometryError(
            f"{error.source}{where}: point {error.point!r}: {error.reason} ({error.failed} of {error.total} points "
            "failed; --skip-failed writes the others)") from None
    print(f"intersected {summary.written} of {summary.points} points (ray residual RMS {summary.rms_px:.3f} px, "
          f"sigma0 {calibration.sigma0_px:.3f} px); wrote {args.out}")
    pointing = HAND_CLICK_SIGMA_PX if args.pointing_sigma is None else args.pointing_sigma
    said = ("given" if args.pointing_sigma is not None else "the hand-click default; --pointing-sigma PX states yours")
    print("; ".join([f"pointing sigma {pointing:g} px ({said})", *calibration_marks(calibration)]))
    if summary.misfits:
        chance = summary.written * MISFIT_SIGNIFICANCE
        print(f"warning: {summary.misfits} of {summary.written} points' rays miss more than a {pointing:g} px "
              f"pointing sigma explains (about {chance:.2g} by chance); the first, {summary.first_misfit.text}: "
              "a mismatched pair, picks less precise than --pointing-sigma, or a calibration that does not fit; "
              "their sigmas do not include this miss")
    if summary.unplaced:
        names = ", ".join(summary.unplaced[:5]) + (f" and {len(summary.unplaced) - 5} more"
                                                   if len(summary.unplaced) > 5 else "")
        print(f"note: pair(s) {names} are no calibrated station: their points are in the first station's "
              f"({calibration.stations[0]}) object frame, as if the rig stood there (--station to choose one, "
              "--frame rig for the left camera's frame)")
    for point, reason in summary.skipped:
        print(f"  skipped point {point}: {reason}")
    return 0
