"""A project's contents summarised, and files imported into it: the command line's ``project info`` and
``project import`` (and anyone else) ask here.

Importing reads and checks every file first, then stores everything in ONE transaction: all of it, or
(on any error) nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from usvips.app.calibration_size import calibration_dict_size_check
from usvips.app.calibrations import store_calibration
from usvips.app.video_project import proxy_bytes
from usvips.core.deployment import Deployment, Georeference
from usvips.core.errors import InputFileError, InvalidParameterError, UsvipsError, concerning
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.io.manifest import ROLES
from usvips.io.tables import read_control, read_observations, refuse_off_every_image, refuse_outside_image
from usvips.store.interface import ProjectStore
from usvips.store.records import Pair, ProjectError


def media_files(project: ProjectStore) -> list[Path]:
    """Every media file the project holds that is reachable here (pairs' images, videos' chapters): the
    inputs a command working on the project must never write over. Missing or unreadable ones are left
    out (nothing can be destroyed there)."""
    stored = [path for pair in project.pairs() for path in (pair.left, pair.right) if path]
    stored += [path for video in project.videos() for camera in ("left", "right") for path in video.paths(camera)]
    found = []
    for path in dict.fromkeys(stored):
        try:
            found.append(project.media_path(path))
        except UsvipsError:
            continue
    return found


@dataclass(frozen=True)
class PairSummary:
    """An image pair: label, medium ("air"/"water"), stored image paths (None when none), active calibration."""

    label: str
    medium: str
    left: str | None
    right: str | None
    calibration_id: int | None


@dataclass(frozen=True)
class VideoSummary:
    """A stereo video: label, frames, frame rate (frames/s), offset (right frame = left frame + offset),
    active calibration."""

    label: str
    frame_count: int
    fps: float
    offset_frames: int
    calibration_id: int | None
    proxy_bytes: int = 0  # its seek proxies on disk (usvips.app.video_project.proxy_bytes)
    medium: str = "water"  # what the cameras looked through ("air"/"water"), its pair's medium


@dataclass(frozen=True)
class ReviewCounts:
    """How many stored measurements are in each review state. Each instant of an object over several
    instants is measured — and reviewed — on its own, so these count objects and their further instants
    alike (their sum is ``object_count + instant_count`` of the summary)."""

    unreviewed: int = 0
    accepted: int = 0
    flagged: int = 0

    @property
    def total(self) -> int:
        return self.unreviewed + self.accepted + self.flagged


@dataclass(frozen=True)
class CalibrationSummary:
    """A stored calibration: id, name, phase ("air" = phase 1, "water" = phase 2; "joint" in older
    projects), sigma0 (pixels) and the pairs and videos it is active for."""

    id: int
    name: str
    phase: str | None
    sigma0_px: float | None
    active_for: tuple[str, ...]


@dataclass(frozen=True)
class ProjectSummary:
    """Schema version, counts of pairs (a video's own pair included), control points and objects (an
    object over several instants counts once: ``object_count`` excludes its further instants, counted in
    ``instant_count``); the image pairs that are not a video's, and the videos; the deployments by scope
    ("" = the project's, else a video's label), the georeference (None when the project has none) and the
    review counts."""

    version: int
    pair_count: int
    control_count: int
    object_count: int
    pairs: tuple[PairSummary, ...]
    videos: tuple[VideoSummary, ...]
    deployments: dict[str, Deployment]
    georeference: Georeference | None
    instant_count: int = 0
    reviews: ReviewCounts = ReviewCounts()
    calibrations: tuple[CalibrationSummary, ...] = ()


def review_counts(project: ProjectStore) -> tuple[int, int, ReviewCounts]:
    """(objects, further instants, review counts) of ``project``: two reads (every object's review, the
    instant links), no vertices."""
    reviews = project.reviews()
    further = len(project.instant_links())
    states = [r.state for r in reviews]
    counts = ReviewCounts(states.count("unreviewed"), states.count("accepted"), states.count("flagged"))
    return len(reviews) - further, further, counts


def objects_text(objects: int, instants: int) -> str:
    """``5 objects`` or ``5 objects (3 further instants)``: an instant is not a further object."""
    text = f"{objects} object" + ("" if objects == 1 else "s")
    return text + (f" ({instants} further instant{'' if instants == 1 else 's'})" if instants else "")


def reviews_text(counts: ReviewCounts) -> str:
    """``2 accepted, 1 flagged, 5 unreviewed``."""
    return f"{counts.accepted} accepted, {counts.flagged} flagged, {counts.unreviewed} unreviewed"


def summarise(project: ProjectStore) -> ProjectSummary:
    """What ``project`` holds (reads only)."""
    pairs = project.pairs()
    videos = project.videos()
    video_labels = {v.label for v in videos}
    media = {p.label: p.medium for p in pairs}
    objects, instants, reviews = review_counts(project)
    return ProjectSummary(
        project.version, len(pairs), len(project.control()), objects,
        tuple(PairSummary(p.label, p.medium, p.left, p.right, project.active_calibration(p.label))
              for p in pairs if p.label not in video_labels),
        tuple(VideoSummary(v.label, v.frame_count, v.fps, v.offset_frames,
                           project.active_calibration(v.label), proxy_bytes(project, v.label),
                           media.get(v.label, "water")) for v in videos),
        project.deployments(), project.georeference(), instants, reviews, calibration_summaries(project, pairs))


def calibration_summaries(project: ProjectStore, pairs: list[Pair] | None = None) -> tuple[CalibrationSummary, ...]:
    """Every stored calibration, oldest first, with the pairs and videos it is active for."""
    pairs = project.pairs() if pairs is None else pairs
    active: dict[int, list[str]] = {}
    for pair in pairs:
        calibration_id = project.active_calibration(pair.label)
        if calibration_id is not None:
            active.setdefault(calibration_id, []).append(pair.label)
    return tuple(CalibrationSummary(c.id, c.name, c.phase, c.sigma0_px, tuple(active.get(c.id, ())))
                 for c in project.calibrations())


@dataclass(frozen=True)
class ImportPlan:
    """Files read and checked, ready to store: control points, one pair's observations for a role, a
    calibration (its file dictionary, name and the pairs it becomes active for)."""

    control: object | None = None
    observations: object | None = None
    pair: str | None = None
    role: str = "calibration-water"
    calibration: dict | None = None
    calibration_name: str = ""
    active_for: tuple[str, ...] = ()


def plan_import(control: str | Path | None = None, observations: str | Path | None = None, pair: str | None = None,
                role: str = "calibration-water", calibration: str | Path | None = None,
                active_for: tuple[str, ...] = ()) -> ImportPlan:
    """Read and check every file to import, before any project is touched. ``observations`` needs
    ``pair``; a file holding several pairs gives that pair's rows (it must be one of them), and a file
    of one pair must name ``pair`` in its pair column, if it has one."""
    if not (control or observations or calibration):
        raise UsvipsError("nothing to import: give control points, observations or a calibration")
    if observations and not pair:
        raise concerning(UsvipsError("observations need the image pair they belong to"), "pair")
    if observations and role not in ROLES:
        raise InvalidParameterError("role", f"unknown observation role {role!r}; the roles are {', '.join(ROLES)}",
                                    label="observation role")
    control_points = read_control(control) if control else None
    rows = read_observations(observations) if observations else None
    if rows is not None and len(rows.pair_labels) > 1:
        if pair not in rows.pair_labels:
            raise concerning(InputFileError(str(observations), f"holds observations of {len(rows.pair_labels)} "
                                            f"pairs ({', '.join(rows.pair_labels)[:80]}); name one of them as "
                                            "the image pair"), "pair")
        rows = rows.pair(pair)
    elif rows is not None and rows.pair_labels[0] not in (pair, "1"):  # ("1": the file has no pair column)
        raise concerning(InputFileError(str(observations), f"its pair column says {rows.pair_labels[0]!r}, but "
                                        f"the image pair given is {pair!r}: name the pair the file says (or "
                                        "remove its pair column)"), "pair")
    data = calibration_to_dict(load_calibration(calibration)) if calibration else None
    if rows is not None:
        labels, lines = list(rows.ids), list(rows.lines)
        refuse_off_every_image(observations, labels, lines, rows.left, rows.right)
        if data is not None and pair in active_for:  # the pair's images are the calibration's
            cameras = data["cameras"]
            refuse_outside_image(observations, labels, lines, rows.left, rows.right,
                                 tuple((cameras[side].get("width"), cameras[side].get("height"))
                                       for side in ("left", "right")))
    return ImportPlan(control_points, rows, pair, role, data, Path(calibration).stem if calibration else "",
                      tuple(active_for))


def store_import(project: ProjectStore, plan: ImportPlan) -> list[str]:
    """Store a checked :class:`ImportPlan` in ``project`` in one transaction (a new pair is created); returns
    what changed, a phrase each. Control points REPLACE the stored ones (the phrase says how many were
    there); a pair's observations of a role are added to those stored (a point observed again is refused
    by its id); observations of points no longer given as control points are named: they stay, unused
    until those points are given again."""
    said = []
    with project.transaction():
        if plan.control is not None:
            before = len(project.control())
            project.set_control(plan.control)
            said.append(f"{_count(len(plan.control), 'control point')}" + (f" (replacing the {before} stored)"
                                                                          if before else ""))
        if plan.observations is not None:
            if plan.pair not in {p.label for p in project.pairs()}:
                project.add_pair(plan.pair)
            stored = project.control_observations(plan.role, plan.pair).ids
            again = sorted(set(stored) & set(plan.observations.ids), key=plan.observations.ids.index)
            if again:
                shown = ", ".join(again[:5]) + (f" and {len(again) - 5} more" if len(again) > 5 else "")
                raise ProjectError(f"{project.path}: pair {plan.pair!r}, role {plan.role!r}: point(s) {shown} "
                                   "already have observations stored; nothing was imported")
            project.add_control_observations(plan.observations, plan.role, plan.pair)
            said.append(f"{_count(len(plan.observations), plan.role + ' observation')} of pair {plan.pair!r}"
                        + (f" (added to the {len(stored)} stored)" if stored else ""))
        if plan.calibration is not None:
            calibration_dict_size_check(project, plan.calibration, plan.active_for, plan.calibration_name + ".json")
            store_calibration(project, plan.calibration_name, plan.calibration, plan.active_for)
            said.append(f"calibration {plan.calibration_name!r}")
        if plan.control is not None:
            orphans = _observed_without_control(project)
            if orphans:
                shown = ", ".join(orphans[:5]) + (f" and {len(orphans) - 5} more" if len(orphans) > 5 else "")
                said.append(f"observed points that are no longer control points: {shown} (their observations "
                            "stay, unused until they are given again)")
    return said


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def _observed_without_control(project: ProjectStore) -> list[str]:
    """Ids of points observed in any pair and role that the project's control points do not give."""
    given = set(project.control().ids)
    missing: dict[str, None] = {}
    for pair in project.pairs():
        for role in ROLES:
            for pid in project.control_observations(role, pair.label).ids:
                if pid not in given:
                    missing[pid] = None
    return list(missing)
