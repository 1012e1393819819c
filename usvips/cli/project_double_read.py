"""``usvips project double-read PROJECT --readers A B [--tolerance-s S | --tolerance-frames N] [--gate-m G] [--k K]
[--csv OUT]``:
compare the objects two annotators measured on the same videos and image pairs (the double-read report,
:mod:`usvips.app.double_read`): the agreement statistics, then the pairs whose figures differ by more than
k combined σ, the species conflicts and each reader's unmatched objects; ``--csv`` writes every row
(also the pairs that agree). Read-only; works on a file or a server survey."""

from __future__ import annotations

import argparse
import math


def register_double_read_action(actions: argparse._SubParsersAction) -> None:
    report = actions.add_parser("double-read", help="compare two annotators' measurements of the same fish "
                                "(pairs, disagreements beyond k combined sigma, unmatched objects, agreement)")
    report.add_argument("project", help="the project file, or postgresql://USER@HOST[:PORT]/DATABASE")
    report.add_argument("--readers", nargs=2, metavar=("A", "B"), required=True,
                        help="the two annotators (creators of the objects) to compare")
    report.add_argument("--tolerance-s", type=float, default=None, metavar="S",
                        help="largest time between two readings of one fish on a video, seconds (default 0.5)")
    report.add_argument("--tolerance-frames", type=int, default=None, metavar="N",
                        help="the same in frames of the video (instead of --tolerance-s)")
    report.add_argument("--gate-m", type=float, default=0.3, metavar="G",
                        help="largest distance between the 3-D midpoints of two readings of one fish, metres "
                        "(default 0.3)")
    report.add_argument("--k", type=float, default=2.0, metavar="K",
                        help="flag pairs whose figures differ by more than K combined sigma (default 2)")
    report.add_argument("--csv", metavar="OUT", help="write every row of the report to this CSV file")
    report.add_argument("--force", action="store_true", help="replace OUT even when it is a USVIPS project or "
                        "calibration (the old file is kept as OUT.bak)")
    report.set_defaults(handler=run_double_read)


def _mm(value: float | None) -> str:
    return "—" if value is None or math.isnan(value) else f"{1000 * value:.1f}"


def run_double_read(args: argparse.Namespace) -> int:
    from usvips.app.double_read import COLUMNS, double_read
    from usvips.core.errors import InvalidParameterError
    from usvips.io.atomic import replacing
    from usvips.io.double_read_table import write_double_read_csv
    from usvips.store.location import is_server_location
    from usvips.store.opening import open_project

    options = {"tolerance_s": "--tolerance-s", "tolerance_frames": "--tolerance-frames", "gate_m": "--gate-m",
               "k": "--k"}
    if args.tolerance_s is not None and args.tolerance_frames is not None:
        raise InvalidParameterError("--tolerance-frames", "give the time tolerance in seconds (--tolerance-s) or in "
                                    "frames (--tolerance-frames), not both")
    tolerance_s = 0.5 if args.tolerance_s is None and args.tolerance_frames is None else args.tolerance_s

    def report_of():
        with open_project(args.project, read_only=True) as project:
            try:
                return double_read(project, args.readers[0], args.readers[1], tolerance_s, args.gate_m, args.k,
                                   tolerance_frames=args.tolerance_frames)
            except InvalidParameterError as error:  # named as the option the user typed
                raise InvalidParameterError(options.get(error.parameter, error.parameter), error.problem) from None

    if args.csv:
        local = None if is_server_location(args.project) else args.project
        with replacing(args.csv, [], local, replace=args.force, parameter="csv"):
            report = report_of()
            rows = report.rows()
            write_double_read_csv(args.csv, COLUMNS, rows, report.summary())
    else:
        report = report_of()
        rows = report.rows()
    for line in report.summary():
        print(line)
    listed = [r for r in rows if r["row"] != "agreement"]
    if listed:
        print(f"{'row':<17} {'A':>6} {'B':>6}  {'where':<14} {'species':<28} {'A mm':>8} {'B mm':>8} "
              f"{'A−B mm':>8} {'σ mm':>6}")
    for r in listed:
        print(f"{r['row']:<17} {r['object_a'] or '':>6} {r['object_b'] or '':>6}  {r['source']:<14} "
              f"{(r['species'] or 'unidentified')[:28]:<28} {_mm(r['value_a']):>8} {_mm(r['value_b']):>8} "
              f"{_mm(r['difference']):>8} {_mm(r['combined_sigma']):>6}")
    if args.csv:
        print(f"wrote {len(rows)} rows to {args.csv}")
    return 0
