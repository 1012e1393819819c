"""``usvips calibration import|export|report``: calibrations exchanged with OpenCV, and their printable report.

import: OpenCV FileStorage YAML/XML (one file or the stereo sample's intrinsics.yml + extrinsics.yml) or
NumPy .npz, or 11 DLT coefficients per camera (``--format dlt``) → a USVIPS calibration file. export: a
USVIPS calibration → OpenCV's stereo file (the in-air model; what OpenCV cannot hold is named on one warning
line each). report: a PDF a survey archives.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from usvips.io.atomic import replacing
from usvips.io.calibration_file import load_calibration, save_calibration
from usvips.io.opencv_calibration import (
    UNITS,
    baseline_doubt,
    opencv_targets,
    parse_image_size,
    read_opencv_stereo,
    sigma0_statement,
    write_opencv_stereo,
)

#: the help of every verb's --force
FORCE_HELP = ("replace --out even when it is an input of the command or holds a USVIPS calibration or project "
              "(the old file is kept as NAME.bak)")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("calibration", help="import, export or report a calibration")
    verbs = parser.add_subparsers(dest="verb", metavar="VERB", required=True)

    importer = verbs.add_parser("import", help="OpenCV YAML/XML (one file, intrinsics + extrinsics, or each "
                                "camera's file then R and T), ROS camera_info pairs, or .npz → JSON")
    importer.add_argument("files", nargs="+", metavar="FILE", help="OpenCV stereo calibration file(s); one camera's "
                          "files left first, then right")
    importer.add_argument("--out", required=True, help="USVIPS calibration file to write (JSON)")
    importer.add_argument("--image-size", metavar="WxH", help="image size in pixels, where the files do not carry it")
    importer.add_argument("--unit", choices=sorted(UNITS), default="m",
                          help="unit of OpenCV's T (the board's unit; default m)")
    importer.add_argument("--sigma0", type=float, metavar="PX",
                          help="the calibration's sigma0 (pixels, one image coordinate); default: from the residual "
                               "the file states (rms, avg_reprojection_error, per-view errors), else 0.5 px marked "
                               "assumed")
    importer.add_argument("--format", choices=["opencv", "dlt"], default="opencv",
                          help="opencv (default) or dlt: 11 DLT coefficients per camera (StereoMorph, DLTdv, Argus, "
                               "VidSync: 11 rows, a column per camera, or a row of 11 per camera)")
    importer.add_argument("--cameras", nargs=2, type=int, default=[1, 2], metavar=("LEFT", "RIGHT"),
                          help="dlt: the numbers (from 1) of the left and right camera in the file (default 1 2)")
    importer.add_argument("--origin", choices=["top-left", "bottom-left"], default="top-left",
                          help="dlt: where the tool's pixel origin is (DLTdv and Argus: bottom-left, y up; needs "
                               "--image-size)")
    importer.add_argument("--one-based", action="store_true",
                          help="dlt: the tool's first pixel is at 1 (MATLAB), not 0")
    importer.add_argument("--force", action="store_true", help=FORCE_HELP)
    importer.set_defaults(handler=run_import)

    exporter = verbs.add_parser("export", help="a USVIPS calibration → OpenCV's stereo file (in-air model)")
    exporter.add_argument("calibration", help="USVIPS calibration file (JSON)")
    exporter.add_argument("--format", choices=["opencv"], default="opencv", help="target format")
    exporter.add_argument("--out", required=True,
                          help="file (.yml, .xml, .json) or an existing folder (intrinsics.yml + extrinsics.yml)")
    exporter.add_argument("--force", action="store_true", help=FORCE_HELP)
    exporter.set_defaults(handler=run_export)

    reporter = verbs.add_parser("report", help="a printable PDF report of a calibration")
    reporter.add_argument("calibration", help="USVIPS calibration file (JSON)")
    reporter.add_argument("--out", required=True, help="PDF to write")
    reporter.add_argument("--check", metavar="OBS.csv",
                          help="check points (id,xl,yl,xr,yr) not used in the calibration, ids in the control")
    reporter.add_argument("--check-control", metavar="CONTROL.csv",
                          help="their true coordinates (default: the calibration's own control file)")
    reporter.add_argument("--force", action="store_true", help=FORCE_HELP)
    reporter.set_defaults(handler=run_report)


def run_import_dlt(args: argparse.Namespace, size: tuple[int, int] | None) -> int:
    from usvips.core.errors import InvalidParameterError
    from usvips.io.dlt_coefficients import calibration_from_dlt

    if len(args.files) != 1:
        raise InvalidParameterError("FILE", f"a DLT import reads one file of coefficients, got {len(args.files)}")
    if args.origin == "bottom-left" and size is None:
        raise InvalidParameterError("--origin", "bottom-left needs --image-size (y is flipped over the height)")
    names = {"cameras": "--cameras", "sigma0": "--sigma0", "unit": "--unit"}
    with replacing(args.out, args.files, replace=args.force):
        try:
            calibration, cameras = calibration_from_dlt(args.files[0], tuple(args.cameras), args.origin,
                                                        args.one_based, size, args.unit, args.sigma0)
        except InvalidParameterError as error:
            raise InvalidParameterError(names.get(error.parameter, error.parameter), error.problem) from None
        save_calibration(calibration, args.out)
    baseline = float(np.linalg.norm(calibration.relative.base))
    print(f"wrote {args.out}: in-air stereo rig from DLT coefficients, baseline {baseline:.4f} m, "
          f"f {cameras['left'].f:.2f} / {cameras['right'].f:.2f} px")
    print(sigma0_statement(calibration) + (" (--sigma0 PX gives it)" if calibration.sigma0_origin == "assumed" else ""))
    for side, camera in cameras.items():
        effect = calibration.statistics["skew_px"][side]
        if max(effect[band] for band in ("top", "middle", "bottom")) >= 0.001:  # rounding's skew is none
            print(f"  {side} camera: skew {camera.skew:.3g} px dropped (USVIPS's interior has none): x moves by at "
                  f"most {effect['top']:.3g} px in the top third of the image, {effect['middle']:.3g} px in the "
                  f"middle, {effect['bottom']:.3g} px in the bottom third")
    return 0


def run_import(args: argparse.Namespace) -> int:
    size = parse_image_size(args.image_size) if args.image_size else None
    if args.format == "dlt":
        return run_import_dlt(args, size)
    with replacing(args.out, args.files, replace=args.force):
        calibration = read_opencv_stereo(args.files, size, args.unit, args.sigma0)
        doubt = baseline_doubt(calibration, args.unit)
        if doubt:
            print(f"usvips calibration import: warning: {doubt} (set the unit with --unit)", file=sys.stderr)
        save_calibration(calibration, args.out)
    left, right = calibration.left, calibration.right
    where = f"{left.width}x{left.height} px" if left.width else "image size unknown (--image-size)"
    baseline = float(np.linalg.norm(calibration.relative.base))
    print(f"wrote {args.out}: in-air stereo rig, baseline {baseline:.4f} m, "
          f"f {left.interior.f:.2f} / {right.interior.f:.2f} px, {where}")
    print(sigma0_statement(calibration) + (" (--sigma0 PX gives it)" if calibration.sigma0_origin == "assumed" else ""))
    return 0



def run_export(args: argparse.Namespace) -> int:
    with replacing(opencv_targets(args.out), [args.calibration], replace=args.force):
        calibration = load_calibration(args.calibration)
        left_out = write_opencv_stereo(calibration, args.out)
    for line in left_out:
        print(f"usvips calibration export: warning: {line}", file=sys.stderr)
    print(f"wrote {args.out}")
    return 0


def run_report(args: argparse.Namespace) -> int:
    # deferred: matplotlib takes ~0.5 s to import, and every `usvips` command builds the whole parser
    from usvips.app.board_report import is_from_target, target_report_data
    from usvips.io.calibration_report import write_calibration_report

    with replacing(args.out, [args.calibration, args.check, args.check_control], replace=args.force):
        calibration = load_calibration(args.calibration)
        # a calibration from target views names a target and images or a video: its views are found again
        data = target_report_data(calibration, args.calibration) if is_from_target(calibration) else None
        pages = write_calibration_report(calibration, args.out, args.calibration, args.check, args.check_control,
                                         data=data)
    print(f"wrote {args.out} ({pages} pages)")
    return 0
