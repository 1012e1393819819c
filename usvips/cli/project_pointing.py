"""``usvips project pointing PROJECT [--from-repeats NAME | --from-double-read A B | --from-tracking] [--use]
[--gate-px G] [--use-estimate N]``: the project's own pointing σ (:mod:`usvips.app.pointing_settings`,
docs/pointing.md). Without an option: the stored estimates, oldest first, numbered. ``--from-…``: estimate
from the project's repeated picks of one annotator, two annotators' double readings, or its tracked
instants, and print it; with ``--use`` store it, dated, as the one in use (for that annotator; for anyone
from double readings; for tracked points from tracking) — every figure is then computed with it.
``--use-estimate N``: make stored estimate N the one in use again."""

from __future__ import annotations

import argparse


def register_pointing_action(actions: argparse._SubParsersAction) -> None:
    pointing = actions.add_parser("pointing", help="the project's own pointing sigma: list the stored estimates, "
                                  "or estimate one from repeated picks, double readings or tracked instants")
    pointing.add_argument("project", help="the project file, or postgresql://USER@HOST[:PORT]/DATABASE")
    source = pointing.add_mutually_exclusive_group()
    source.add_argument("--from-repeats", metavar="NAME", help="from the points NAME picked more than once on the "
                        "same image")
    source.add_argument("--from-double-read", nargs=2, metavar=("A", "B"),
                        help="from the vertices annotators A and B both picked on the same images")
    source.add_argument("--from-tracking", action="store_true", help="from the spread of tracked instants")
    source.add_argument("--use-estimate", type=int, metavar="N", help="make stored estimate N the one in use")
    pointing.add_argument("--use", action="store_true", help="store the new estimate as the one in use")
    pointing.add_argument("--gate-px", type=float, default=8.0, metavar="G",
                          help="largest distance (px) between two picks of one point (default 8)")
    pointing.set_defaults(handler=run_pointing)


def _table(records) -> list[str]:
    header = ["#", "annotator", "source", "sigma px", "95 % interval", "n", "method", "date", "in use", "note"]
    rows = [[str(i + 1), r.who, r.source, f"{r.estimate.sigma_px:.3f}",
             f"{r.estimate.low_px:.3f}–{r.estimate.high_px:.3f}", str(r.estimate.n), r.estimate.method, r.date,
             "yes" if r.in_use else "", r.note] for i, r in enumerate(records)]
    table = [header, *rows]
    widths = [max(len(line[k]) for line in table) for k in range(len(header))]
    return ["  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True)).rstrip() for line in table]


def run_pointing(args: argparse.Namespace) -> int:
    from usvips.app import pointing_settings as settings
    from usvips.core.errors import InvalidParameterError
    from usvips.store.opening import open_project

    if not 0 < args.gate_px < float("inf"):
        raise InvalidParameterError("--gate-px", f"must be a positive number of pixels, got {args.gate_px:g}")
    estimating = args.from_repeats or args.from_double_read or args.from_tracking
    if args.use and not estimating:
        raise InvalidParameterError("--use", "stores a new estimate: give --from-repeats, --from-double-read or "
                                             "--from-tracking")
    writes = args.use or args.use_estimate is not None
    with open_project(args.project, read_only=not writes) as project:
        if args.use_estimate is not None:
            count = len(settings.stored_estimates(project))
            if not 1 <= args.use_estimate <= count:
                raise InvalidParameterError("--use-estimate", f"no stored estimate {args.use_estimate}: the project "
                                                              f"has {count}")
            settings.use_estimate(project, args.use_estimate - 1)
        if not estimating:
            for line in _table(settings.stored_estimates(project)):
                print(line)
            return 0
        if args.from_repeats:
            estimate, note = settings.estimate_repeats(project, args.from_repeats, args.gate_px)
            annotator, source = args.from_repeats, "hand click"
        elif args.from_double_read:
            estimate, note = settings.estimate_double_readings(project, *args.from_double_read, args.gate_px)
            annotator, source = "", "hand click"
        else:
            estimate, note = settings.estimate_tracking(project)
            annotator, source = "", "tracked"
        print(f"pointing σ ({source}, {annotator or 'anyone'}): {estimate.summary()}; from {note}")
        if args.use:
            stored = settings.add_estimate(project, estimate, annotator, source, note=note)
            print(f"stored {stored.date} as the one in use: every figure of these picks is computed with it")
    return 0
