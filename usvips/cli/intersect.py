"""``usvips intersect``: 3-D points with sigmas from conjugate pixels and a calibration.

The sigmas combine the picks' pointing precision (``--pointing-sigma PX``, pixels per image coordinate;
without it the hand-click default of ``usvips.core.pointing`` — never the calibration's sigma0, which is
that of its own corners or targets) and the calibration's own uncertainty (its parameter covariance,
propagated to every point)."""

from __future__ import annotations

import argparse

import numpy as np

from usvips.cli.common import add_pointing_option, csv_text, write_text_atomic
from usvips.core.calibration.uncertainty import intersect_with_calibration
from usvips.core.errors import DegenerateGeometryError
from usvips.core.intersection import Intersection
from usvips.core.measurements import calibration_marks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX
from usvips.core.rays import RayStatus
from usvips.io.atomic import replacing
from usvips.io.calibration_file import load_calibration
from usvips.io.tables import read_observations, refuse_outside_image


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("intersect", help="intersect conjugate pixels: id,X,Y,Z,sX,sY,sZ (metres)")
    parser.add_argument("--calibration", required=True, help="calibration file (JSON)")
    parser.add_argument("--obs", required=True, help="observations CSV: id,xl,yl,xr,yr (pixels)")
    parser.add_argument("--out", required=True, help="points CSV to write")
    parser.add_argument("--station", default="0",
                        help="calibrated station (index or pair label) whose object frame to use (default: first)")
    parser.add_argument("--frame", choices=["object", "rig"], default="object",
                        help="object: the control frame at the station; rig: left perspective centre, left axes")
    parser.add_argument("--pointing-only", action="store_true",
                        help="sigmas from the pointing precision alone, without the calibration's own uncertainty")
    add_pointing_option(parser)
    parser.add_argument("--skip-failed", action="store_true",
                        help="write the points that intersect and list the others, instead of stopping")
    parser.add_argument("--force", action="store_true", help="replace --out even when it is an input or holds a "
                        "USVIPS calibration or project (the old file is kept as NAME.bak)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    with replacing(args.out, [args.calibration, args.obs], replace=args.force):
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    calibration = load_calibration(args.calibration)
    observations = read_observations(args.obs)
    refuse_outside_image(args.obs, list(observations.ids), list(observations.lines), observations.left,
                         observations.right, ((calibration.left.width, calibration.left.height),
                                              (calibration.right.width, calibration.right.height)))
    station = int(args.station) if args.station.isdigit() else args.station
    pointing = HAND_CLICK_SIGMA_PX if args.pointing_sigma is None else args.pointing_sigma
    result = intersect_with_calibration(calibration, observations.left, observations.right, station, args.frame,
                                        include_calibration=not args.pointing_only, pointing_sigma_px=pointing)
    failed = np.flatnonzero(~result.ok)
    if failed.size and not args.skip_failed:
        first = int(failed[0])
        line = f", line {observations.lines[first]}" if observations.lines else ""
        raise DegenerateGeometryError(
            f"{args.obs}{line}: point {observations.ids[first]!r}: {RayStatus(int(result.status[first])).reason}"
            f" ({failed.size} of {len(observations)} points failed; --skip-failed writes the others)")
    write_text_atomic(args.out, csv_text(["id", "X", "Y", "Z", "sX", "sY", "sZ"], point_rows(observations.ids, result)))
    written = int(result.ok.sum())
    rms = float(np.sqrt(np.mean(result.residuals_px[result.ok] ** 2))) if result.ok.any() else 0.0
    print(f"intersected {written} of {len(observations)} points (ray residual RMS {rms:.3f} px, "
          f"sigma0 {calibration.sigma0_px:.3f} px); wrote {args.out}")
    said = ("given" if args.pointing_sigma is not None else "the hand-click default; --pointing-sigma PX states yours")
    print("; ".join([f"pointing sigma {pointing:g} px ({said})", *calibration_marks(calibration)]))
    for i in failed:
        print(f"  skipped point {observations.ids[i]}: {RayStatus(int(result.status[i])).reason}")
    return 0


def point_rows(ids: tuple[str, ...], result: Intersection) -> list[list[str]]:
    """CSV rows ``id, X, Y, Z, sX, sY, sZ`` (metres, 6 decimals) of the intersected points, in input order.

    Linear in the number of points: the sigmas are computed once for all rows and every number is
    formatted in one pass over a flat list (no per-row work on whole arrays)."""
    ok = np.flatnonzero(result.ok)
    table = np.column_stack([result.points[ok], result.sigmas[ok]])
    texts = [f"{v:.6f}" for v in table.ravel().tolist()]
    return [[ids[i], *texts[6 * row:6 * row + 6]] for row, i in enumerate(ok.tolist())]
