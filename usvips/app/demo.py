"""The demo: a sample project's calibration and check points, headless, step by step.

Reads the project's manifest: phase 1 from its ``calibration-air`` observations, phase 2 from its
``calibration-water`` ones (housing from the manifest), then intersects every ``check`` file whose pair
was calibrated and compares with the control coordinates. :func:`run_demo` yields each step's result as
soon as it is computed, so that the command line prints (and a window shows) progress; nothing here
prints. Units: pixels for the adjustments, metres for the check points.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvips.core import housing as housings
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.report import CalibrationReport
from usvips.core.calibration.uncertainty import intersect_with_calibration
from usvips.core.errors import UsvipsError
from usvips.io.manifest import read_manifest, split_known
from usvips.io.tables import read_control, read_observations
from usvips.locations import sample_project

#: the project the demo runs when none is named: the thesis's water tank
DEFAULT_PROJECT = sample_project("tank_1995")


@dataclass(frozen=True)
class DemoStart:
    """The sample's name and description (the first step)."""

    name: str
    description: str


@dataclass(frozen=True)
class ExcludedTarget:
    """A target the adjustment left out of one image: ``side`` "left" or "right"; ``w`` its normalised
    residual (None when it was left out for ``reason``)."""

    id: str
    side: str
    w: float | None
    reason: str


@dataclass(frozen=True)
class PhaseSummary:
    """One calibration phase: ``title`` (phase, housing, file), σ0 and residual RMS (px), redundancy, and
    the targets left out (one per target and image, the y coordinate's verdict first), and the control
    points demoted to tie points as control-coordinate blunders (one message each)."""

    title: str
    sigma0_px: float
    rms_px: float
    redundancy: int
    excluded: tuple[ExcludedTarget, ...]
    demoted: tuple[str, ...] = ()


@dataclass(frozen=True)
class CheckSummary:
    """A check file intersected with the final calibration: ``count`` points in the file; for the ones
    with control coordinates whose rays met, their ``ids``, computed − control ``errors`` (K, 3) m, their
    ``sigmas`` (K, 3) m and the per-axis RMS of the errors (3,) m."""

    file: str
    count: int
    ids: tuple[str, ...]
    errors: np.ndarray
    sigmas: np.ndarray
    rms: np.ndarray


@dataclass(frozen=True)
class SkippedCheck:
    """A check file whose pairs have no calibration of their own."""

    file: str
    pairs: tuple[str, ...]


DemoStep = DemoStart | PhaseSummary | CheckSummary | SkippedCheck


def run_demo(project: str | Path = DEFAULT_PROJECT) -> Iterator[DemoStep]:
    """Calibrate the sample at ``project`` (a directory with ``project.json``) and intersect its check
    points, yielding :class:`DemoStart`, a :class:`PhaseSummary` per phase, then a :class:`CheckSummary`
    or :class:`SkippedCheck` per check file. A project without control or in-air observations is a
    :class:`UsvipsError` naming its manifest."""
    manifest = read_manifest(project)
    if manifest.control is None:
        raise UsvipsError(f"{manifest.path}: the project has no control file to calibrate with")
    control = read_control(manifest.control)
    air_files, water_files = _files(manifest, "calibration-air"), _files(manifest, "calibration-water")
    if not air_files:
        raise UsvipsError(f"{manifest.path}: the project has no in-air calibration observations")
    yield DemoStart(manifest.name, manifest.description)
    air = calibrate_air(control, read_observations(air_files[0].file), CalibrationOptions())
    yield phase_summary(air.report, f"phase 1 (in air, {air_files[0].file.name})")
    calibration = air.calibration
    if water_files and manifest.housing in housings.water_names():
        fix_values, priors = split_known(manifest.housing_known)
        water = calibrate_water(calibration, manifest.housing, control, read_observations(water_files[0].file),
                                CalibrationOptions(fix_values=fix_values, priors=priors))
        yield phase_summary(water.report, f"phase 2 ({manifest.housing}, {water_files[0].file.name})")
        calibration = water.calibration
        calibrated_pairs = set(water_files[0].pairs)
    else:
        calibrated_pairs = set(air_files[0].pairs)
    for entry in _files(manifest, "check"):
        if entry.pairs and not set(entry.pairs) <= calibrated_pairs:
            yield SkippedCheck(entry.file.name, tuple(entry.pairs))
            continue
        check = read_observations(entry.file)
        result = intersect_with_calibration(calibration, check.left, check.right)
        known = [i for i, pid in enumerate(check.ids) if pid in control.ids and result.ok[i]]
        truth = control.xyz[control.index_of([check.ids[i] for i in known])]
        errors = result.points[known] - truth
        yield CheckSummary(entry.file.name, len(check), tuple(check.ids[i] for i in known), errors,
                           result.sigmas[known], np.sqrt(np.mean(errors**2, axis=0)))


def phase_summary(report: CalibrationReport, title: str) -> PhaseSummary:
    """A calibration result's report (σ0, RMS, redundancy, suspects, demoted control points) as a
    :class:`PhaseSummary`: each suspect target once per image, the y coordinate's verdict first; each
    demoted control point's message."""
    seen, excluded = set(), []
    for suspect in sorted(report.suspects, key=lambda s: s.coordinate != "y"):
        key = (suspect.point, suspect.side)
        if key in seen:
            continue
        seen.add(key)
        excluded.append(ExcludedTarget(str(suspect.point), "left" if suspect.side == "l" else "right",
                                       suspect.w, suspect.reason or ""))
    demoted = tuple(blunder.message for blunder in report.control_blunders)
    return PhaseSummary(title, report.sigma0_px, report.rms_px, report.redundancy, tuple(excluded), demoted)


def _files(manifest, role: str) -> list:
    return [entry for entry in manifest.observations if entry.role == role]
