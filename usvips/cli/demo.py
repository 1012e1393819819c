"""``usvips demo [PROJECT]``: run a sample project's calibration and check points headless, print results.

The work is :func:`usvips.app.demo.run_demo`; this module parses the arguments and prints each step as it
comes (check points in centimetres).
"""

from __future__ import annotations

import argparse

from usvips.app.demo import DEFAULT_PROJECT, CheckSummary, DemoStart, PhaseSummary, SkippedCheck, run_demo


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("demo", help="calibrate a sample project and intersect its check points (headless)")
    parser.add_argument("project", nargs="?", default=str(DEFAULT_PROJECT),
                        help="a sample project directory with project.json (default: the thesis's water tank)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    for step in run_demo(args.project):
        if isinstance(step, DemoStart):
            print(f"{step.name}: {step.description}\n")
        elif isinstance(step, PhaseSummary):
            _print_phase(step)
        elif isinstance(step, SkippedCheck):
            print(f"\n{step.file}: skipped (pair {', '.join(step.pairs)} has no calibration of its own)")
        elif isinstance(step, CheckSummary):
            _print_check(step)
    return 0


def _print_phase(phase: PhaseSummary) -> None:
    print(f"{phase.title}: sigma0 {phase.sigma0_px:.3f} px, residual RMS {phase.rms_px:.3f} px, "
          f"redundancy {phase.redundancy}")
    for message in phase.demoted:
        print(f"  demoted to a tie point: {message}")
    for target in phase.excluded:
        what = f"w = {target.w:.1f}" if target.w is not None else target.reason
        print(f"  excluded target {target.id} in the {target.side} image: {what}")


def _print_check(check: CheckSummary) -> None:
    print(f"\n{check.file}: {check.count} check points (computed − control, centimetres)")
    print(f"  {'id':>4} {'dX':>7} {'dY':>7} {'dZ':>7}   {'sX':>6} {'sY':>6} {'sZ':>6}")
    for pid, error, sigma in zip(check.ids, check.errors, check.sigmas, strict=True):
        d, s = error * 100, sigma * 100
        print(f"  {pid:>4} {d[0]:7.2f} {d[1]:7.2f} {d[2]:7.2f}   {s[0]:6.2f} {s[1]:6.2f} {s[2]:6.2f}")
    rms = check.rms * 100
    print(f"  RMS  {rms[0]:7.2f} {rms[1]:7.2f} {rms[2]:7.2f}")
