"""``usvips bench``: print the benchmark table as JSON."""

from __future__ import annotations

import argparse
import json
import platform
import sys

from usvips.core.errors import InvalidParameterError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "bench", help="measure speed as ratios against baselines timed in the same run (JSON)")
    parser.add_argument("--only", nargs="*", metavar="AREA",
                        help="run only these areas (modules of usvips.bench)")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="problem size relative to the nominal one (default 1.0)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from usvips import bench

    if not 0 < args.scale <= 10:
        raise InvalidParameterError("--scale", f"must be in (0, 10], got {args.scale}")
    unknown = set(args.only or ()) - set(bench.BENCH_MODULES)
    if unknown:
        raise InvalidParameterError("--only", f"unknown area(s) {sorted(unknown)}; "
                                    f"known: {list(bench.BENCH_MODULES)}")
    rows = bench.run(args.only, args.scale)
    report = {"python": platform.python_version(), "machine": platform.machine(), "results": rows}
    json.dump(report, sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0
