"""``usvips project check PROJECT [--json] [--out FILE]``: the quality report of a survey — every object
that breaks a rule (ray RMS, precision/length, range, length against the species' maximum), with the
value, the limit and where it was measured. ``--sigma [--replicas R] [--seed S] [--pointing-sigma PX]``:
instead, whether the stated σ hold for the project's own geometry (:mod:`usvips.app.sigma_check`): a table of
NEES per object kind with its 95 % interval."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING

from usvips.cli.common import csv_text, write_text_atomic
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.io.atomic import replacing

if TYPE_CHECKING:
    from usvips.core.measurements import QualityRules

# numpy, SciPy and OpenCV (through the quality check and the project store) are imported by the handler
# only: ``usvips project --help`` registers this action without them


def register_check_action(actions: argparse._SubParsersAction) -> None:
    check = actions.add_parser("check", help="list every object that breaks a quality rule (ray RMS, "
                               "precision/length, range, length > the species' maximum) and where it is")
    check.add_argument("project")
    check.add_argument("--json", action="store_true", help="print the report as JSON")
    check.add_argument("--force", action="store_true",
                   help="replace --out even when it is an input or holds a USVIPS project or "
                        "calibration (the old file is kept as NAME.bak)")
    check.add_argument("--out", help="write the report: FILE.csv (comma separated) or any other name (tab "
                       "separated, as CheckEM's tables)")
    check.add_argument("--max-rms-mm", type=float, default=20.0, help="ray-intersection RMS limit (default 20)")
    check.add_argument("--max-precision", type=float, default=10.0,
                       help="precision/length limit in %% (default 10)")
    check.add_argument("--max-range-m", type=float, default=8.0, help="range limit in metres (default 8)")
    check.add_argument("--fail-on", choices=("error", "warning"),
                       help="exit 1 when an object breaks a rule (error), or also when a rule could not be "
                            "checked (warning): for pipelines; without it the exit status is 0. With --sigma: when "
                            "a kind's stated σ are too small (error), or also too large (warning)")
    check.add_argument("--sigma", action="store_true",
                       help="instead: check whether the stated σ hold, by a Monte Carlo of the project's own "
                            "geometry (its calibrations, picks and pointing σ): NEES per object kind")
    check.add_argument("--replicas", type=int, help="with --sigma: Monte Carlo replicas (default 40)")
    check.add_argument("--seed", type=int, help="with --sigma: the random seed (default 0)")
    check.add_argument("--pointing-sigma", type=float, metavar="PX",
                       help="with --sigma: the pointing σ (pixels, one coordinate) believed true of every pick "
                            "(default: the project's estimates in use, else each figure's own)")
    check.set_defaults(handler=run_check)


def _rules(args: argparse.Namespace) -> QualityRules:
    from usvips.core.measurements import QualityRules

    for option, value in (("--max-rms-mm", args.max_rms_mm), ("--max-precision", args.max_precision),
                          ("--max-range-m", args.max_range_m)):
        if not value > 0 or value == float("inf"):
            raise InvalidParameterError(option, f"must be a positive number, got {value:g}")
    return QualityRules(args.max_rms_mm / 1000, args.max_precision / 100, args.max_range_m)


def run_sigma_check(args: argparse.Namespace) -> int:
    from usvips.app.sigma_check import COLUMNS, check_project_sigmas
    from usvips.store.opening import open_project

    if args.replicas < 2 or args.replicas > 10_000:
        raise InvalidParameterError("--replicas", f"must be 2 to 10000, got {args.replicas}")
    if args.seed < 0:
        raise InvalidParameterError("--seed", f"must be 0 or more, got {args.seed}")
    if args.pointing_sigma is not None and not (0 < args.pointing_sigma < float("inf")):
        raise InvalidParameterError("--pointing-sigma", f"must be a positive number of pixels, got "
                                                        f"{args.pointing_sigma:g}")
    if args.out:
        raise InvalidParameterError("--out", "is not written by --sigma: use --json and redirect it")
    with open_project(args.project, read_only=True) as project:
        report = check_project_sigmas(project, args.replicas, args.seed, args.pointing_sigma)
    # --fail-on error: the stated σ of some kind are too small (figures claim more than they hold);
    # warning: also too large (honest but pessimistic)
    failing = {k.verdict for k in report.check.kinds} & ({"too small"} if args.fail_on == "error" else
                                                           {"too small", "too large"} if args.fail_on else set())
    if args.json:
        print(json.dumps(report.as_dict(), indent=1))
        return 1 if failing else 0
    table = [list(COLUMNS), *report.rows()]
    widths = [max(len(line[k]) for line in table) for k in range(len(COLUMNS))]
    for line in table:
        print("  ".join(cell.ljust(width) for cell, width in zip(line, widths, strict=True)).rstrip())
    for line in report.summary():
        print(line)
    return 1 if failing else 0


def run_check(args: argparse.Namespace) -> int:
    from usvips.app.quality import REPORT_COLUMNS, check_project, report_rows

    if args.sigma:
        args.replicas = 40 if args.replicas is None else args.replicas
        args.seed = 0 if args.seed is None else args.seed
        return run_sigma_check(args)
    alone = [o for o, v in (("--replicas", args.replicas), ("--seed", args.seed),
                            ("--pointing-sigma", args.pointing_sigma)) if v is not None]
    if alone:
        raise UsvipsError(f"{alone[0]} goes with --sigma (the Monte Carlo check of the stated σ); without it the "
                          "rules are checked and it would be ignored")
    from usvips.store.opening import open_project

    rules = _rules(args)
    from usvips.app.project_contents import media_files

    with open_project(args.project, read_only=True) as project:
        report = check_project(project, rules)
        media = media_files(project) if args.out else []
    rows = report_rows(report)
    if args.out:
        text = csv_text(REPORT_COLUMNS, rows)
        if not args.out.lower().endswith(".csv"):
            text = "\n".join("\t".join(str(c).replace("\t", " ") for c in row)
                             for row in [REPORT_COLUMNS, *rows]) + "\n"
        with replacing(args.out, media, project=args.project, replace=args.force):
            write_text_atomic(args.out, text)
    if args.json:
        print(json.dumps({"checked": report.checked, "failing_objects": report.failing_objects,
                          "issues": [i.as_dict() for i in report.issues]}, indent=1))
        return _status(report, args.fail_on)
    shown = [REPORT_COLUMNS.index(c) for c in ("ObjectId", "Genus species", "Rule", "Status", "Value", "Limit",
                                                "Unit", "Where")]
    table = [[REPORT_COLUMNS[k] for k in shown]] + [[str(row[k]) for k in shown] for row in rows]
    widths = [max(len(line[k]) for line in table) for k in range(len(shown))]
    for line in table:
        print("  ".join(cell.ljust(width) for cell, width in zip(line, widths, strict=True)).rstrip())
    print(report.summary() + (f"; the report is in {args.out}" if args.out else ""))
    return _status(report, args.fail_on)


def _status(report, fail_on: str | None) -> int:
    """0, or 1 when ``--fail-on`` names a level the report reaches (a pipeline's failed check)."""
    return 1 if fail_on and report.exceeds(fail_on) else 0
