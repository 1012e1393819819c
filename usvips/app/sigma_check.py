"""``usvips project check --sigma`` and the window's σ check: do the project's stated σ hold for its own
geometry? (:mod:`usvips.core.sigma_check`: a Monte Carlo of its calibrations, its picks and their pointing σ.)

Each survey object (one per fish: a further instant is not checked on its own) is read as the window and
the exports read it (:func:`usvips.app.project_figures.measurement_input`) and its first instant measured
from its picks as the one figure function measures it — the objects of one calibration at once
(:func:`usvips.core.measurements.batch.measure_picks_many`, tested equal to ``measure_picks``): its vertices
are the truth of the replicas and its main figure's σ is the σ stated. Objects whose calibration is not in the
project (figures from stored values) cannot be simulated: they are counted as such.

The pointing σ the replicas draw (what is believed TRUE of the picks) is, for each vertex, the one its
figure is stated with — its own, the project's estimate in use for its source and annotator
(:mod:`usvips.app.pointing_settings`), else its source's default; ``pointing_px`` overrides it for every
pick (e.g. to ask "what if we click with 1 px?").

Reading (:func:`read_check`, on the project's thread) is split from the Monte Carlo (:func:`run_check`,
any thread; the window runs it in its worker with progress and cancel).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from usvips.app.object_instants import survey_objects
from usvips.app.pointing_settings import pointing_in_use
from usvips.app.project_figures import instants_by_object, measurement_input
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.measurements.batch import measure_picks_many
from usvips.core.sigma_check import HOLDS, REPLICAS, CheckedObject, CheckGeometry, SigmaCheck, check_sigmas
from usvips.store.interface import ProjectStore

#: the table's columns (CLI and window alike)
COLUMNS = ("kind", "objects", "replicas", "NEES", "95 % interval", "verdict", "worst object")


@dataclass(frozen=True)
class CheckInput:
    """What the Monte Carlo needs, read from the project: the objects and their geometries, and what could
    not be checked (one line each: "object N: why")."""

    objects: tuple[CheckedObject, ...]
    geometries: tuple[CheckGeometry, ...]
    skipped: tuple[str, ...]
    pointing_note: str


@dataclass(frozen=True)
class SigmaReport:
    """The check's result (:class:`~usvips.core.sigma_check.SigmaCheck`) with what was read."""

    check: SigmaCheck
    read: CheckInput

    def rows(self) -> list[list[str]]:
        """The table's rows (:data:`COLUMNS`), one per kind."""
        return [[k.kind, str(k.objects), str(k.replicas), f"{k.nees:.2f}", f"{k.low:.2f}–{k.high:.2f}", k.verdict,
                 f"{k.worst[0]} ({k.worst[1]:.1f})"] for k in self.check.kinds]

    def summary(self) -> list[str]:
        """What the table means, in words."""
        lines = [f"pointing σ drawn: {self.read.pointing_note}",
                 f"NEES: the mean of ((value − truth) / stated σ)² of each kind's main figure over "
                 f"{self.check.replicas} replicas; the stated σ hold when it lies in {HOLDS[0]:g}–{HOLDS[1]:g} "
                 "('too small': the errors are larger than stated)"]
        if self.read.skipped:
            lines.append(f"not checked: {len(self.read.skipped)} object(s) — " + "; ".join(self.read.skipped[:5])
                         + (" …" if len(self.read.skipped) > 5 else ""))
        return lines

    def as_dict(self) -> dict:
        return {"replicas": self.check.replicas, "pointing": self.read.pointing_note,
                "kinds": [{"kind": k.kind, "objects": k.objects, "nees": k.nees, "low": k.low, "high": k.high,
                           "verdict": k.verdict, "worst_object": k.worst[0], "worst_mean_square": k.worst[1],
                           "skipped": k.skipped} for k in self.check.kinds],
                "not_checked": list(self.read.skipped)}


def read_check(project: ProjectStore, pointing_px: float | None = None) -> CheckInput:
    """Read what the σ check of ``project`` needs (on the project's thread); ``pointing_px``: the pointing σ
    (px) believed true of every pick, instead of the project's own (see the module docstring)."""
    if pointing_px is not None and not (np.isfinite(pointing_px) and pointing_px > 0):
        raise InvalidParameterError("pointing_px", f"must be a positive number of pixels, got {pointing_px:g}")
    in_use = pointing_in_use(project)
    cache: dict = {}
    instants = instants_by_object(project)
    groups: dict[tuple[int, str, str], list] = {}
    skipped = []
    for stored in survey_objects(project):
        first = replace(measurement_input(project, stored, cache, instants=instants, pointing=in_use), instants=())
        if first.calibration is None or first.calibration_id is None:
            skipped.append(f"object {stored.id}: its calibration is not in the project")
            continue
        groups.setdefault((first.calibration_id, str(first.station), first.frame), []).append((stored, first))
    geometries, objects = [], []
    for members in groups.values():
        _, head = members[0]
        # the objects of one calibration measured at once, each exactly as the one figure function does
        measured = measure_picks_many([f.kind for _, f in members], head.calibration, [f.left for _, f in members],
                                      [f.right for _, f in members], head.station, head.frame,
                                      [f.pointing_px for _, f in members])
        geometries.append(CheckGeometry(head.calibration, head.station, head.frame))
        for (stored, _), m in zip(members, measured, strict=True):
            if isinstance(m, UsvipsError):
                skipped.append(f"object {stored.id}: {m}")
                continue
            if not m.main.sigma > 0:
                skipped.append(f"object {stored.id}: its {m.main.label} has no σ")
                continue
            count = len(m.points)
            true = (np.full((count, 2), float(pointing_px)) if pointing_px is not None
                    else np.broadcast_to(m.pointing_sigma_px, (count, 2)).copy())
            objects.append(CheckedObject(str(stored.id), m.kind, m.points, m.main.sigma, len(geometries) - 1, true))
    if pointing_px is not None:
        note = f"{pointing_px:g} px for every pick (given)"
    elif in_use:
        note = "the σ each figure is stated with (the project's estimates in use where they apply)"
    else:
        note = "the σ each figure is stated with (the sources' defaults: the project has no estimate in use)"
    return CheckInput(tuple(objects), tuple(geometries), tuple(skipped), note)


def run_check(read: CheckInput, replicas: int = REPLICAS, seed: int = 0, cancel: Callable[[], bool] | None = None,
              progress: Callable[[int, int], None] | None = None) -> SigmaReport:
    """The Monte Carlo over what :func:`read_check` read (any thread)."""
    if not read.objects:
        why = f" ({read.skipped[0]})" if read.skipped else ""
        raise UsvipsError(f"no object can be checked: the project has no object measured from picks with a "
                          f"calibration it holds{why}")
    return SigmaReport(check_sigmas(read.objects, read.geometries, replicas, seed, cancel, progress), read)


def check_project_sigmas(project: ProjectStore, replicas: int = REPLICAS, seed: int = 0,
                         pointing_px: float | None = None) -> SigmaReport:
    """:func:`read_check` then :func:`run_check`."""
    return run_check(read_check(project, pointing_px), replicas, seed)
