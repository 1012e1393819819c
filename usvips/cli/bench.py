"""``usvips bench``: print the benchmark table as JSON."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys

from usvips.core.errors import InvalidParameterError
from usvips.io.atomic import check_output_path, write_text_atomic


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "bench", help="measure speed as ratios against baselines timed in the same run (JSON)",
        description="Every area runs in a process of its own; an area that fails gives a row naming its "
                    "error, the others still report, and the command then exits with status 1.")
    parser.add_argument("--only", nargs="*", metavar="AREA",
                        help="run only these areas (modules of usvips.bench; --list names them)")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="problem size relative to the nominal one (default 1.0; 0.01 is a quick smoke test)")
    parser.add_argument("--list", action="store_true", help="name the areas and their modules, run nothing")
    parser.add_argument("--out", metavar="FILE", help="also write the report to FILE, again after each area (a run "
                        "stopped part-way keeps the areas done)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from usvips import bench

    if not 0 < args.scale <= 10:
        raise InvalidParameterError("--scale", f"must be in (0, 10], got {args.scale}")
    known = bench.areas()
    if args.list:
        for name, module in known.items():
            print(f"{name}\t{module}")
        return 0
    unknown = set(args.only or ()) - set(known)
    if unknown:
        raise InvalidParameterError("--only", f"unknown area(s) {sorted(unknown)}; known: {list(known)}")
    if args.out:
        check_output_path(args.out)
    load = os.getloadavg()[0]

    def report(runs: list) -> dict:
        return {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
                "scale": args.scale, "load_1min_at_start": round(load, 2),
                "load_1min_at_end": round(os.getloadavg()[0], 2),
                "wall_s": round(sum(r.wall_s for r in runs), 1), "areas": [r.summary() for r in runs],
                "results": [row for r in runs for row in r.rows]}

    def done(runs: list) -> None:
        last = runs[-1]
        print(f"usvips bench: area {last.area}: {len(last.rows)} rows in {last.wall_s:.0f} s"
              + (f" (failed: {last.error})" if last.error else ""), file=sys.stderr, flush=True)
        if args.out:
            write_text_atomic(args.out, json.dumps(report(runs), indent=2) + "\n")

    runs = bench.run_areas(args.only, args.scale, done=done)
    json.dump(report(runs), sys.stdout, indent=2)
    sys.stdout.write("\n")
    failed = [r for r in runs if r.error is not None]
    for area in failed:
        print(f"usvips bench: area {area.area} failed: {area.error}", file=sys.stderr)
    return 1 if failed else 0
