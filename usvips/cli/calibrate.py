"""``usvips calibrate air|water``: phase 1 and phase 2 (or joint) calibration from CSV files, with the
control from a control file or a target description (``--target``), optionally validated on held-out
views (``--holdout``)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from usvips.cli import board_sources
from usvips.cli.common import parse_assignment, parse_prior, write_text_atomic
from usvips.core import housing as housings
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.phases import observes_a_plane, require_physical
from usvips.core.calibration.validation import validate
from usvips.core.errors import ConvergenceError, InvalidParameterError
from usvips.core.observations import ControlPoints
from usvips.io.adjustment_report import report_text
from usvips.io.atomic import guard_output, replacing
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.io.tables import read_control, read_observations, refuse_outside_image
from usvips.io.target_file import read_target

#: the longest image side accepted (pixels; the largest sensors are ~10^5 px wide)
MAX_IMAGE_SIDE = 100_000
#: the housing's known geometry: the library's name of each quantity → its option
GEOMETRY_OPTIONS = {"distance": "--port-distance", "thickness": "--glass-thickness", "n_glass": "--n-glass",
                    "n_water": "--n-water"}


def _common(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--control", help="control CSV: id,X,Y,Z[,sX,sY,sZ] (metres)")
    where.add_argument("--target", metavar="TARGET.json",
                       help="a calibration target's description (a board or a 3-D field; `usvips target "
                            "describe` writes one): its points are the control, and a board's printed geometry is "
                            "taken as exact (not searched for misprints)")
    parser.add_argument("--obs", help="observations CSV: id,xl,yl,xr,yr[,pair] (pixels); with a "
                        "target, the pair column labels the views (or find them: --images, --video)")
    board_sources.add_arguments(parser)
    parser.add_argument("--holdout", type=float, metavar="SHARE",
                        help="hold out this share of the views (e.g. 0.2), calibrate on the rest and print how well "
                             "the calibration predicts the held-out views (reprojection, known distances by range); "
                             "the calibration written is the one from the rest")
    parser.add_argument("--seed", type=int, default=0, help="seed of the choice of held-out views (default 0)")
    parser.add_argument("--out", required=True, help="calibration file to write (JSON)")
    parser.add_argument("--force", action="store_true",
                    help="replace --out and --report even when it is an input or holds a USVIPS project or "
                         "calibration (the old file is kept as NAME.bak)")
    parser.add_argument("--report", help="adjustment report to write (JSON)")
    parser.add_argument("--free", nargs="+", action="extend", default=[], metavar="NAME",
                        help="parameters to free (seeds' symbols apply to both cameras, e.g. k2 p1)")
    parser.add_argument("--fix", nargs="+", action="extend", default=[], metavar="NAME[=VALUE]",
                        help="parameters to hold fixed, at a value if given (e.g. t=0.016 k1_r)")
    parser.add_argument("--prior", nargs="+", action="extend", default=[], metavar="NAME=VALUE:SIGMA",
                        help="weight a parameter towards a value (e.g. n2=1.60:0.01)")
    parser.add_argument("--sigma-px", type=float, default=0.5,
                        help="a-priori standard deviation of a measured pixel coordinate (default 0.5)")
    parser.add_argument("--image-size", metavar="WxH", help="image size in pixels, e.g. 568x488")
    parser.add_argument("--no-snooping", action="store_true", help="do not exclude blunders")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("calibrate", help="calibrate a stereo rig (phase 1 in air, phase 2 underwater)")
    phases = parser.add_subparsers(dest="phase", metavar="PHASE", required=True)
    air = phases.add_parser("air", help="phase 1: both cameras in air (collinearity with distortion; DLT start, "
                            "or a planar start from board views)")
    _common(air)
    air.set_defaults(handler=run_air)
    water = phases.add_parser("water", help="phase 2: housing and exterior by ray tracing; several pairs = joint")
    water.add_argument("--base", required=True, help="the phase-1 calibration file")
    water.add_argument("--housing", required=True, choices=housings.water_names(),
                       help="; ".join(f"{k.kind}: {k.description}" for k in housings.registered_kinds()
                                      if k.kind in housings.water_names()))
    water.add_argument("--interior", choices=["fixed", "weighted"], default="weighted",
                       help="phase-1 interior weighted by its phase-1 covariance (default: its uncertainty "
                            "reaches every point) or held fixed as in the thesis (the sigmas then leave it out)")
    water.add_argument("--cameras-unmoved", action="store_true",
                       help="the cameras did not move between the air and the water images (e.g. a target in a "
                            "tank photographed before and after filling it): each view's poses are held at "
                            "phase 1's (a view takes the phase-1 view of the same label, or the only one)")
    water.add_argument("--air-without-glass", action="store_true",
                       help="with --cameras-unmoved: the air images were not taken through the flat port or tank "
                            "wall (by default the shift the glass gave phase 1's poses is undone)")
    for quantity, flag in GEOMETRY_OPTIONS.items():
        water.add_argument(flag, dest=f"geometry_{quantity}", metavar="VALUE[:SIGMA]",
                           help=f"known {housings.GEOMETRY[quantity]}: held at VALUE, or weighted ± SIGMA")
    _common(water)
    water.set_defaults(handler=run_water, parameter_options={**water.get_default("parameter_options"),
                                                             **GEOMETRY_OPTIONS})


def _geometry(args: argparse.Namespace) -> dict[str, tuple[float, float | None]]:
    """The known housing geometry from --port-distance, --glass-thickness, --n-glass, --n-water."""
    out: dict[str, tuple[float, float | None]] = {}
    for quantity in housings.GEOMETRY:
        text = getattr(args, f"geometry_{quantity}", None)
        if text is None:
            continue
        flag = GEOMETRY_OPTIONS.get(quantity, f"--{quantity.replace('_', '-')}")
        value, _, sigma = text.partition(":")
        try:
            out[quantity] = (float(value), float(sigma) if sigma else None)
        except ValueError:
            raise InvalidParameterError(flag, f"expected VALUE or VALUE:SIGMA, got {text!r}") from None
        if not all(np.isfinite(v) for v in out[quantity] if v is not None):
            raise InvalidParameterError(flag, f"expected finite numbers, got {text!r}")
        if out[quantity][1] is not None and not out[quantity][1] > 0:
            raise InvalidParameterError(flag, f"the sigma must be > 0, got {text!r}")
    return out


def _options(args: argparse.Namespace) -> CalibrationOptions:
    fix_names, fix_values = [], {}
    for item in args.fix:
        if "=" in item:
            name, value = parse_assignment("--fix", item)
            fix_values[name] = value
        else:
            fix_names.append(item)
    priors = dict(parse_prior(item) for item in args.prior)
    freed = set(args.free)
    both = sorted(freed & (set(fix_names) | set(fix_values)))
    if both:
        raise InvalidParameterError("--free/--fix", f"{both[0]} is both freed and fixed; choose one")
    both = sorted(freed & set(priors))
    if both:
        raise InvalidParameterError("--free/--prior", f"{both[0]} is both freed and given a prior; choose one")
    if args.report and Path(args.report).resolve() == Path(args.out).resolve():
        raise InvalidParameterError("--report", f"is the same file as --out ({args.out}); the report would "
                                    "overwrite the calibration")
    if not (np.isfinite(args.sigma_px) and args.sigma_px > 0):
        raise InvalidParameterError("--sigma-px", f"must be a finite number > 0, got {args.sigma_px}")
    size = (None, None)
    if args.image_size:
        width, sep, height = args.image_size.lower().partition("x")
        if not sep or not width.isdigit() or not height.isdigit():
            raise InvalidParameterError("--image-size", f"expected WIDTHxHEIGHT, got {args.image_size!r}")
        size = (int(width), int(height))
        if min(size) < 16 or max(size) > MAX_IMAGE_SIDE:
            raise InvalidParameterError("--image-size", f"{args.image_size} is no image (each side must be "
                                        f"16 to {MAX_IMAGE_SIDE} pixels)")
    if args.holdout is not None and not 0.0 < args.holdout < 1.0:
        raise InvalidParameterError("--holdout", f"the share of views held out must be between 0 and 1, got "
                                    f"{args.holdout}")
    return CalibrationOptions(free=tuple(args.free), fix=tuple(fix_names), fix_values=fix_values, priors=priors,
                              sigma_px=args.sigma_px, interior=getattr(args, "interior", "weighted"),
                              snooping=not args.no_snooping, image_size=size,
                              cameras_unmoved=bool(getattr(args, "cameras_unmoved", False)),
                              air_through_glass=not getattr(args, "air_without_glass", False),
                              housing_geometry=_geometry(args))


def _control(args: argparse.Namespace, options: CalibrationOptions) -> ControlPoints:
    """The control from ``--control`` or from ``--target`` (then ``options.control_exact`` follows the
    target: a printed board's geometry is exact by construction)."""
    if args.control:
        return read_control(args.control)
    target = read_target(args.target)
    options.control_exact = bool(target.exact)
    return target.control_points()


def _calibrate(fit, control: ControlPoints, observations, args: argparse.Namespace, options: CalibrationOptions,
               compare_opencv: bool):
    """Run ``fit(observations)`` — on all views, or with ``--holdout`` on the rest after holding out a share
    of them — and return (result, validation or None)."""
    if args.holdout is None:
        return fit(observations), None
    planar_in_air = compare_opencv and observes_a_plane(control, observations)
    validation = validate(control, observations, args.holdout, fit, args.seed,
                          compare_opencv=planar_in_air and options.image_size != (None, None),
                          image_size=options.image_size)
    if planar_in_air and options.image_size == (None, None):
        validation.notes.append("OpenCV's solution of the same views is put beside ours when --image-size is given")
    return validation.result, validation


def _finish(result, args: argparse.Namespace, validation=None, base=None) -> int:
    if validation is not None:
        result.calibration.statistics["validation"] = validation.as_dict()
    if not result.adjustment.converged:
        raise ConvergenceError(f"the calibration did not converge ({result.adjustment.reason}); nothing written")
    if result.calibration.phase != "air":
        require_physical(result, base, "nothing written")
    report = result.report
    # write both files only once everything has succeeded
    calibration_text = json.dumps(calibration_to_dict(result.calibration), indent=2, allow_nan=False) + "\n"
    report_file = report_text(report, validation.as_dict() if validation is not None else None) if args.report \
        else None
    with replacing(_outputs(args), _inputs(args), replace=args.force):
        write_text_atomic(args.out, calibration_text)
        if report_file is not None:
            write_text_atomic(args.report, report_file)
    print(f"{report.phase} calibration ({report.housing}, stations {', '.join(report.stations)}): "
          f"sigma0 {report.sigma0_px:.3f} px, RMS {report.rms_px:.3f} px"
          + (f" over the kept, {report.rms_px_all:.3f} px over all observations" if report.set_aside
             and report.rms_px_all is not None else "")
          + f", redundancy {report.redundancy}, "
          f"condition {report.condition_number:.3g}")
    for suspect in report.suspects:
        w = f"w = {suspect.w:.1f}" if suspect.w is not None else suspect.reason
        print(f"  excluded: point {suspect.point} {suspect.side} {suspect.coordinate} (pair {suspect.group}): {w}")
    for blunder in report.control_blunders:
        print(f"  control blunder: {blunder.message}")
    for pair in report.correlations[:10]:
        print(f"  correlation {pair.a} ~ {pair.b}: {pair.r:+.3f}")
    if validation is not None:
        for line in validation.lines():
            print(line)
    print(f"wrote {args.out}" + (f" and {args.report}" if args.report else ""))
    return 0


def _inputs(args: argparse.Namespace) -> list:
    """Every file the command reads: no output may be written over one of them."""
    return [getattr(args, name, None) for name in ("control", "target", "obs", "base")] + board_sources.inputs(args)


def _outputs(args: argparse.Namespace) -> list:
    return [args.out] + ([args.report] if args.report else [])


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse, before any work, an output that is one of the inputs (an image included) or a project or
    calibration file (unless --force; :func:`usvips.io.atomic.guard_output`)."""
    for path, parameter in zip(_outputs(args), ("out", "report"), strict=False):
        guard_output(path, _inputs(args), replace=args.force, parameter=parameter)


def _source(args: argparse.Namespace) -> dict:
    where = {"control": str(args.control)} if args.control else {"target": str(args.target)}
    return {**where, "observations": str(args.obs),
            **({"base": str(args.base)} if getattr(args, "base", None) else {})}


def _observations(args: argparse.Namespace, options: CalibrationOptions):
    """The observations of ``--obs``; with ``--image-size``, one outside the image is an error naming its line
    (an image size smaller than the pictures, or a pixel in other units)."""
    observations = read_observations(args.obs)
    if options.image_size != (None, None):
        refuse_outside_image(args.obs, list(observations.ids), list(observations.lines),
                             observations.left, observations.right, (options.image_size, options.image_size))
    return observations


def run_air(args: argparse.Namespace) -> int:
    options = _options(args)
    _check_outputs(args)
    if board_sources.wants_views(args):
        done = board_sources.calibrate(args, "air", options)
        return _finish(done.result, args, done.validation)
    control = _control(args, options)
    observations = _observations(args, options)
    result, validation = _calibrate(lambda obs: calibrate_air(control, obs, options, _source(args)), control,
                                    observations, args, options, compare_opencv=True)
    return _finish(result, args, validation)


def run_water(args: argparse.Namespace) -> int:
    base = load_calibration(args.base)
    if base.phase != "air":
        raise InvalidParameterError("--base", f"{args.base} is a {base.phase} (phase-2) calibration; phase 2 "
                                    "starts from the in-air (phase-1) calibration of the same cameras")
    options = _options(args)
    _check_outputs(args)
    if board_sources.wants_views(args):
        done = board_sources.calibrate(args, "water", options, base, args.housing)
        return _finish(done.result, args, done.validation, base)
    control = _control(args, options)
    observations = _observations(args, options)
    result, validation = _calibrate(
        lambda obs: calibrate_water(base, args.housing, control, obs, options, _source(args)), control,
        observations, args, options, compare_opencv=False)
    return _finish(result, args, validation, base)
