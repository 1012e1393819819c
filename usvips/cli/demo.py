"""``usvips demo [PROJECT]``: run a sample project's calibration and check points headless, print results.

Reads the project's manifest: phase 1 from its ``calibration-air`` observations, phase 2 from its
``calibration-water`` ones (housing from the manifest), then intersects every ``check`` file whose pair
was calibrated and compares with the control coordinates.
"""

from __future__ import annotations

import argparse

import numpy as np

from usvips.core import housing as housings
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.uncertainty import intersect_with_calibration
from usvips.core.errors import UsvipsError
from usvips.io.manifest import read_manifest, split_known
from usvips.io.tables import read_control, read_observations
from usvips.locations import sample_project

DEFAULT_PROJECT = sample_project("tank_1995")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("demo", help="calibrate a sample project and intersect its check points (headless)")
    parser.add_argument("project", nargs="?", default=str(DEFAULT_PROJECT),
                        help="a sample project directory with project.json (default: the thesis's water tank)")
    parser.set_defaults(handler=run)


def _files(manifest, role: str) -> list:
    return [entry for entry in manifest.observations if entry.role == role]


def _summary(result, title: str) -> None:
    report = result.report
    print(f"{title}: sigma0 {report['sigma0_px']:.3f} px, residual RMS {report['rms_px']:.3f} px, "
          f"redundancy {report['redundancy']}")
    seen = set()
    for suspect in sorted(report["suspects"], key=lambda s: s["coordinate"] != "y"):
        key = (suspect["id"], suspect["side"])
        if key in seen:
            continue
        seen.add(key)
        what = f"w = {suspect['w']:.1f}" if suspect["w"] is not None else suspect["reason"]
        image = "left" if suspect["side"] == "l" else "right"
        print(f"  excluded target {suspect['id']} in the {image} image: {what}")


def run(args: argparse.Namespace) -> int:
    manifest = read_manifest(args.project)
    if manifest.control is None:
        raise UsvipsError(f"{manifest.path}: the project has no control file to calibrate with")
    control = read_control(manifest.control)
    air_files, water_files = _files(manifest, "calibration-air"), _files(manifest, "calibration-water")
    if not air_files:
        raise UsvipsError(f"{manifest.path}: the project has no in-air calibration observations")
    print(f"{manifest.name}: {manifest.description}\n")
    air = calibrate_air(control, read_observations(air_files[0].file), CalibrationOptions())
    _summary(air, f"phase 1 (in air, {air_files[0].file.name})")
    calibration = air.calibration
    if water_files and manifest.housing in housings.water_names():
        fix_values, priors = split_known(manifest.housing_known)
        water = calibrate_water(calibration, manifest.housing, control, read_observations(water_files[0].file),
                                CalibrationOptions(fix_values=fix_values, priors=priors))
        _summary(water, f"phase 2 ({manifest.housing}, {water_files[0].file.name})")
        calibration = water.calibration
        calibrated_pairs = set(water_files[0].pairs)
    else:
        calibrated_pairs = set(air_files[0].pairs)
    for entry in _files(manifest, "check"):
        if entry.pairs and not set(entry.pairs) <= calibrated_pairs:
            print(f"\n{entry.file.name}: skipped (pair {', '.join(entry.pairs)} has no calibration of its own)")
            continue
        check = read_observations(entry.file)
        result = intersect_with_calibration(calibration, check.left, check.right)
        known = [i for i, pid in enumerate(check.ids) if pid in control.ids and result.ok[i]]
        print(f"\n{entry.file.name}: {len(check)} check points (computed − control, centimetres)")
        print(f"  {'id':>4} {'dX':>7} {'dY':>7} {'dZ':>7}   {'sX':>6} {'sY':>6} {'sZ':>6}")
        truth = control.xyz[control.index_of([check.ids[i] for i in known])]
        errors = result.points[known] - truth
        for row, i in enumerate(known):
            d, s = errors[row] * 100, result.sigmas[i] * 100
            print(f"  {check.ids[i]:>4} {d[0]:7.2f} {d[1]:7.2f} {d[2]:7.2f}   {s[0]:6.2f} {s[1]:6.2f} {s[2]:6.2f}")
        rms = np.sqrt(np.mean(errors**2, axis=0)) * 100
        print(f"  RMS  {rms[0]:7.2f} {rms[1]:7.2f} {rms[2]:7.2f}")
    return 0
