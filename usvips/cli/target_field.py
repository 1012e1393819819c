"""``usvips target field PROJECT --pair LABEL --clicks CLICKS.csv [--control C.csv] [--calibration ID|active]
[--mark disc|cross] [--store [--accept-doubtful ID,…]]``: find the rest of a 3-D target field in a pair's
two images from the targets identified in each (the clicks file: ``side,id,x,y``, pixels), print what was
found, doubtful and missing, and with ``--store`` keep the found targets as the pair's control
observations for the classic calibration.

Registered as an action of ``usvips target`` (this module is listed after ``target`` in
:data:`usvips.cli.COMMANDS`). The work is in :mod:`usvips.app.target_field`.
"""

from __future__ import annotations

import argparse

from usvips.core.errors import InputFileError, InvalidParameterError


def _target_actions(subparsers: argparse._SubParsersAction) -> argparse._SubParsersAction:
    """The sub-actions of ``usvips target`` (registered before this module)."""
    target = subparsers.choices["target"]
    return next(a for a in target._actions if isinstance(a, argparse._SubParsersAction))


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = _target_actions(subparsers).add_parser(
        "field", help="find a 3-D target field in a pair's images from 6 or more targets identified in each; "
                      "print found / doubtful / missing; --store keeps them for the calibration")
    parser.add_argument("project", help="the project file, or postgresql://USER@HOST[:PORT]/DATABASE")
    parser.add_argument("--pair", required=True, help="the image pair's label")
    parser.add_argument("--clicks", required=True, metavar="CLICKS.csv",
                        help="the targets identified: side,id,x,y (side left or right; pixels, x right, y down from "
                             "the centre of the top-left pixel); at least 6 per image (4 for a planar field)")
    parser.add_argument("--control", metavar="CONTROL.csv",
                        help="the field's control (id,X,Y,Z in metres) when the project holds none; stored with "
                             "--store (default: the project's control)")
    parser.add_argument("--calibration", metavar="ID",
                        help="an earlier calibration's id (or 'active': the pair's active one): its cameras' interior "
                             "and housing, the pose resected (needed underwater; default: a DLT, in air)")
    parser.add_argument("--mark", choices=("disc", "cross"), default="disc",
                        help="what each target looks like (default disc)")
    parser.add_argument("--store", action="store_true",
                        help="store the targets found in both images as the pair's control observations (role "
                             "calibration-air or calibration-water, by the pair's medium)")
    parser.add_argument("--accept-doubtful", metavar="ID,…", default="",
                        help="with --store: doubtful targets to store too, where they were located (comma-separated "
                             "ids)")
    parser.set_defaults(handler=run_field)


def run_field(args: argparse.Namespace) -> int:
    from usvips.app import target_field as service
    from usvips.app.opening import open_project
    from usvips.io.field_clicks import read_clicks
    from usvips.io.tables import read_control

    accepted = [pid.strip() for pid in args.accept_doubtful.split(",") if pid.strip()]
    if accepted and not args.store:
        raise InvalidParameterError("--accept-doubtful", "only with --store (it says which doubtful targets to store)")
    clicks = read_clicks(args.clicks)
    control = read_control(args.control) if args.control else None
    with open_project(args.project, read_only=not args.store) as project:
        calibration_id = _calibration_id(project, args)
        job = service.prepare(project, args.pair, control, calibration_id, args.mark)
        try:
            result = job.run(clicks.pixels)
        except service.ClickError as error:
            line = clicks.lines.get((error.side, error.target)) if error.target else None
            raise InputFileError(args.clicks, str(error), line) from None
        _print(result, job)
        if not args.store:
            usable = len(result.observations())
            print(f"{usable} target{'s' * (usable != 1)} usable in both images; nothing stored (--store stores "
                  "them; --accept-doubtful ID,… adds doubtful ones)")
            return 0
        confirmed = service.confirm(project, result, _accepted(result, accepted))
    also = " and the control" if confirmed.control_stored else ""
    print(f"stored {confirmed.count} target{'s' * (confirmed.count != 1)} as the {confirmed.role} observations of "
          f"pair {confirmed.pair}{also}")
    if confirmed.one_sided:
        print(f"  not stored (usable in one image only): {', '.join(confirmed.one_sided)}")
    return 0


def _calibration_id(project, args: argparse.Namespace) -> int | None:
    if args.calibration is None:
        return None
    if args.calibration == "active":
        calibration_id = project.active_calibration(args.pair)
        if calibration_id is None:
            raise InvalidParameterError("--calibration", f"pair {args.pair!r} has no active calibration; give its id")
        return calibration_id
    try:
        return int(args.calibration)
    except ValueError:
        raise InvalidParameterError("--calibration", f"{args.calibration!r} is neither a calibration id nor "
                                    "'active'") from None


def _accepted(result, ids: list[str]) -> set[tuple[str, str]]:
    """(side, id) of each accepted id where it is doubtful with a located pixel; an id doubtful in neither
    image is an error naming it."""
    pairs = set()
    for pid in ids:
        sides = [side for side in ("left", "right") if pid in result.side(side).ids("doubtful")
                 and result.side(side).target(pid).pixel is not None]
        if not sides:
            raise InvalidParameterError("--accept-doubtful", f"target {pid!r} is not doubtful with a located pixel "
                                        "in either image")
        pairs.update((side, pid) for side in sides)
    return pairs


def _model(job) -> str:
    if job.cameras is not None:
        return f"calibration {job.calibration_id}'s cameras, pose resected"
    return "a homography (planar field)" if job.needed() == 4 else "a DLT in air (no calibration)"


def _print(result, job) -> None:
    print(f"pair {result.pair!r} ({result.role}): {len(result.control)} control targets, {job.shape}s, found "
          f"through {_model(job)}")
    if job.caution():
        print(f"  note: {job.caution()} (--calibration ID)")
    for side in ("left", "right"):
        print(f"{side:>5}: {result.side(side).summary()}")
        if result.side(side).advice():
            print(f"       {result.side(side).advice()}")
    for status in ("doubtful", "missing"):
        for side in ("left", "right"):
            for target in result.side(side).targets:
                if target.status == status:
                    print(f"  {status} {side} {target.id}: {target.reason}")
