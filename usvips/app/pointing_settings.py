"""A project's own pointing σ: estimated from what the team already has, stored with a date, and the one
in use for each annotator and kind of source.

Estimates (:mod:`usvips.core.pointing_estimates`) are made from the project's objects:

- :func:`estimate_repeats` — objects one annotator measured more than once on the same image (same pair,
  or same video frames), of the same kind, whose picks all lie within ``gate_px`` of each other, vertex by
  vertex, in both images: the same points picked again;
- :func:`estimate_double_readings` — the same, between two annotators (each pair of objects once);
- :func:`estimate_tracking` — the further instants tracked from an object's picks: the spread of each
  tracked vertex over runs of three equally spaced frames (the tracker's own noise, about the track;
  the error of the pick it started from is carried to every frame and is not in it).

An estimate is stored (:func:`add_estimate`) in the project — its σ, interval, degrees of freedom, n,
method, date, for which annotator ("" for anyone) and which kind of source (:data:`usvips.core.pointing.
SOURCES`) — in the project's metadata (``ProjectStore.set_pointing_estimates``: no schema of its own; every
backend and a push/pull carry it). At most one estimate is *in use* per (annotator, source); storing one
for use replaces the one before (kept, not in use). :func:`pointing_in_use` gives the
:class:`~usvips.core.pointing.PointingSigma` a vertex of that source takes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime

import numpy as np

from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.pointing import SOURCES, PointingSigma, default_sigma, source_from_label
from usvips.core.pointing_estimates import (
    METHODS,
    PointingEstimate,
    from_double_readings,
    from_repeats,
    from_tracks,
)
from usvips.store.interface import ProjectStore
from usvips.store.records import StoredObject, Vertex

#: the largest distance (px) between two picks of one point taken as repeats of it (a further pick of the
#: same fish on the same image lies a few σ away; another fish lies much further)
GATE_PX = 8.0
#: 95 % interval half-width → standard uncertainty
_Z95 = 1.959963984540054


@dataclass(frozen=True)
class StoredEstimate:
    """A pointing estimate as the project keeps it: for ``annotator`` ("" for anyone) and a kind of
    ``source`` (a key of :data:`~usvips.core.pointing.SOURCES`), made on ``date`` (ISO 8601 UTC), whether it
    is the one ``in_use`` for them, and ``note``: what it came from, in words."""

    estimate: PointingEstimate
    annotator: str = ""
    source: str = "hand click"
    date: str = ""
    in_use: bool = False
    note: str = ""

    @property
    def pointing_sigma(self) -> PointingSigma:
        """The estimate as a pointing σ in use (origin ``estimated``; its standard uncertainty from the 95 %
        interval, its date, n)."""
        e = self.estimate
        return PointingSigma(e.sigma_px, (e.high_px - e.low_px) / (2 * _Z95), "estimated", self.date[:10], e.n)

    @property
    def who(self) -> str:
        return self.annotator or "anyone"

    def to_dict(self) -> dict:
        e = self.estimate
        return {"annotator": self.annotator, "source": self.source, "date": self.date, "in_use": self.in_use,
                "note": self.note, "sigma_px": e.sigma_px, "low_px": e.low_px, "high_px": e.high_px, "dof": e.dof,
                "effective_dof": e.effective_dof, "n": e.n, "method": e.method,
                "excess_kurtosis": None if not np.isfinite(e.excess_kurtosis) else e.excess_kurtosis,
                "bias_px": None if e.bias_px is None else list(e.bias_px)}

    @classmethod
    def from_dict(cls, record: dict) -> StoredEstimate:
        kurtosis = record.get("excess_kurtosis")
        bias = record.get("bias_px")
        estimate = PointingEstimate(float(record["sigma_px"]), float(record["low_px"]), float(record["high_px"]),
                                    int(record["dof"]), float(record["effective_dof"]), int(record["n"]),
                                    str(record["method"]), float("nan") if kurtosis is None else float(kurtosis),
                                    None if bias is None else (float(bias[0]), float(bias[1])))
        if estimate.method not in METHODS or str(record["source"]) not in SOURCES:
            raise ValueError(f"unknown method {estimate.method!r} or source {record['source']!r}")
        return cls(estimate, str(record.get("annotator", "")), str(record["source"]), str(record.get("date", "")),
                   bool(record.get("in_use", False)), str(record.get("note", "")))


def stored_estimates(project: ProjectStore, raw: list[dict] | None = None) -> list[StoredEstimate]:
    """The project's pointing estimates (``raw``: as already read), oldest first; a record that cannot be
    read is a :class:`UsvipsError` naming the project."""
    try:
        return [StoredEstimate.from_dict(r) for r in (project.pointing_estimates() if raw is None else raw)]
    except (KeyError, TypeError, ValueError, IndexError) as error:
        raise UsvipsError(f"{project.path}: a stored pointing estimate cannot be read ({error}); estimate it "
                          "again") from None


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds").replace("+00:00", "Z")


def add_estimate(project: ProjectStore, estimate: PointingEstimate, annotator: str = "", source: str = "hand click",
                 use: bool = True, note: str = "", date: str | None = None) -> StoredEstimate:
    """Store ``estimate`` for ``annotator`` ("" for anyone) and kind of ``source``, dated ``date`` (default:
    now, UTC); with ``use`` it becomes the one in use for them (the one before stays, not in use)."""
    if source not in SOURCES:
        raise InvalidParameterError("source", f"unknown pointing source {source!r}; known: {', '.join(SOURCES)}")
    stored = StoredEstimate(estimate, annotator.strip(), source, date or _now(), bool(use), note)
    read = project.pointing_estimates()  # the version this change is made on: a colleague's since is refused
    records = stored_estimates(project, read)
    if use:
        records = [replace(r, in_use=False) if (r.annotator, r.source) == (stored.annotator, source) else r
                   for r in records]
    records.append(stored)
    project.set_pointing_estimates([r.to_dict() for r in records], expected=read)
    return stored


def use_estimate(project: ProjectStore, index: int | None, annotator: str = "", source: str = "hand click") -> None:
    """Make the stored estimate number ``index`` (0-based, oldest first) the one in use for its annotator and
    source; ``index`` None: none in use for ``annotator`` and ``source`` (the source's default again)."""
    read = project.pointing_estimates()
    records = stored_estimates(project, read)
    if index is not None:
        if not 0 <= index < len(records):
            raise InvalidParameterError("estimate", f"no stored estimate {index + 1}: the project has {len(records)}")
        annotator, source = records[index].annotator, records[index].source
    records = [replace(r, in_use=(i == index)) if (r.annotator, r.source) == (annotator, source) else r
               for i, r in enumerate(records)]
    project.set_pointing_estimates([r.to_dict() for r in records], expected=read)


def pointing_in_use(project: ProjectStore) -> dict[tuple[str, str], PointingSigma]:
    """(annotator, source) → the pointing σ in use for them ("" annotator: anyone's)."""
    return {(r.annotator, r.source): r.pointing_sigma for r in stored_estimates(project) if r.in_use}


def resolve(in_use: dict[tuple[str, str], PointingSigma], source: str, annotator: str = "") -> PointingSigma | None:
    """The pointing σ in use for a vertex of kind of ``source`` picked by ``annotator``: the annotator's
    own estimate, else anyone's, else None (the source's default applies)."""
    return in_use.get((annotator, source)) or in_use.get(("", source))


def pointing_with_estimates(in_use: dict[tuple[str, str], PointingSigma], vertices: Sequence[Vertex],
                            creator: str = "") -> tuple[list[tuple[float, float] | None], list[str], tuple[str, ...]]:
    """The stated pointing σ (left, right) px or None, and origins, of an object's stored ``vertices`` with
    the project's estimates ``in_use`` applied to those whose σ is their source's default: the estimate for
    the vertex's source and annotator (the source's own annotator, else ``creator``, the object's), else
    anyone's; an auto-matched vertex carries the click it follows, so without an estimate of its own kind
    it takes the hand-click one; a tracked vertex carries the click it was tracked from and the tracker's
    noise (:func:`_tracked`). A σ given by the user or stored as estimated stays. Also the marks
    a figure from them carries: one per estimate used ("pointing sigma 0.42 ± 0.05 px (estimated, …) in use
    for N vertex(es)")."""
    sigmas, origins, used = [], [], {}
    for v in vertices:
        sigma, origin = v.pointing_px, v.pointing_origin if v.pointing_px is not None else "default"
        if origin == "default" and in_use:
            try:
                source = source_from_label(v.source)
            except InvalidParameterError:
                source = None
            if source is not None:
                who = source.annotator or creator
                if source.kind == "tracked":
                    found = _tracked(in_use, who, sigma)
                else:
                    found = resolve(in_use, source.kind, who)
                    if found is None and source.kind == "auto-match":
                        found = resolve(in_use, "hand click", who)
                if found is not None:
                    sigma, origin = (found.value_px, found.value_px), "estimated"
                    used[found.text] = used.get(found.text, 0) + 1
        sigmas.append(sigma)
        origins.append(origin)
    marks = tuple(f"pointing sigma {text} in use for {n} vertex(es)" for text, n in used.items())
    return sigmas, origins, marks


def _tracked(in_use: dict[tuple[str, str], PointingSigma], who: str,
             stored: tuple[float, float] | None) -> PointingSigma | None:
    """A tracked vertex's σ from the estimates in use: the click it was tracked from (the hand-click
    estimate, else the σ stored with it) and the tracker's own noise about its track (a "tracked" estimate,
    :func:`estimate_tracking`) added in variance; None when neither is estimated."""
    click, tracker = resolve(in_use, "hand click", who), resolve(in_use, "tracked", who)
    if click is None and tracker is None:
        return None
    if tracker is None:
        return click
    base = click.value_px if click is not None else (max(stored) if stored is not None else default_sigma())
    return PointingSigma(float(np.hypot(base, tracker.value_px)), tracker.uncertainty_px, "estimated", tracker.date,
                         tracker.n)


# ------------------------------------------------------------------------------------------------ from data
def _where(stored: StoredObject) -> tuple | None:
    """The image an object was measured on: its pair, or its video and frames (None: not known)."""
    if not stored.vertices:
        return None
    v = stored.vertices[0]
    if v.video is not None:
        return ("video", v.video, v.frame_left, v.frame_right)
    return ("pair", v.pair) if v.pair is not None else None


def _picks(stored: StoredObject) -> np.ndarray:
    """(N, 2, 2) picks: vertex, side (left, right), x y."""
    return np.array([[[v.xl, v.yl], [v.xr, v.yr]] for v in stored.vertices], float).reshape(-1, 2, 2)


def _same_points(a: np.ndarray, b: np.ndarray, gate_px: float) -> bool:
    return a.shape == b.shape and bool(np.all(np.linalg.norm(a - b, axis=-1) <= gate_px))


def _by_image(objects: Sequence[StoredObject]) -> dict[tuple, list[StoredObject]]:
    grouped: dict[tuple, list[StoredObject]] = {}
    for o in objects:
        where = _where(o)
        if where is not None and np.all(np.isfinite(_picks(o))):
            grouped.setdefault((o.kind, len(o.vertices), where), []).append(o)
    return grouped


def _annotated(project: ProjectStore, annotator: str | None) -> list[StoredObject]:
    # an instant picked by hand on another frame is a pick of its own image, kept; a tracked one is no pick
    tracked = {i for i, frame in project.instant_sources().items() if frame is not None}
    return [o for o in project.objects() if (annotator is None or o.creator == annotator) and o.id not in tracked]


def repeated_points(project: ProjectStore, annotator: str, gate_px: float = GATE_PX) -> tuple[list[np.ndarray], int]:
    """The repeated picks of ``annotator`` (see the module docstring): groups (k, 2) px, one per vertex and
    image side, and the number of objects they came from. Tracked instants are not picks and are left out."""
    groups, objects = [], 0
    for members in _by_image(_annotated(project, annotator)).values():
        clusters: list[list[np.ndarray]] = []
        for o in members:
            picks = _picks(o)
            home = next((c for c in clusters if _same_points(c[0], picks, gate_px)), None)
            if home is None:
                clusters.append([picks])
            else:
                home.append(picks)
        for cluster in clusters:
            if len(cluster) < 2:
                continue
            objects += len(cluster)
            stack = np.stack(cluster)  # (k, N, 2 sides, 2)
            groups.extend(stack[:, i, side] for i in range(stack.shape[1]) for side in range(2))
    return groups, objects


def estimate_repeats(project: ProjectStore, annotator: str, gate_px: float = GATE_PX) -> tuple[PointingEstimate, str]:
    """``annotator``'s pointing σ from their repeated picks, and what it came from in words; none is an
    :class:`UsvipsError` saying what to measure."""
    groups, objects = repeated_points(project, annotator, gate_px)
    if not groups:
        raise UsvipsError(f"{annotator or 'nobody'} has picked no point twice on the same image (within "
                          f"{gate_px:g} px): measure a few objects again to estimate the pointing σ from repeats")
    return from_repeats(groups), f"{objects} objects measured repeatedly by {annotator}"


def double_read_points(project: ProjectStore, first: str, second: str,
                       gate_px: float = GATE_PX) -> tuple[np.ndarray, np.ndarray, int]:
    """The picks (M, 2) px of the vertices two annotators both measured on the same images (left and right
    stacked; each pair of objects once, nearest first) and the number of object pairs."""
    if first == second:
        raise InvalidParameterError("annotators", f"a double reading needs two annotators, got {first!r} twice")
    a_groups = _by_image(_annotated(project, first))
    b_groups = _by_image(_annotated(project, second))
    rows_a, rows_b, pairs = [], [], 0
    for key, members in a_groups.items():
        others = list(b_groups.get(key, []))
        for o in members:
            picks = _picks(o)
            candidates = [(float(np.mean(np.linalg.norm(_picks(b) - picks, axis=-1))), j)
                          for j, b in enumerate(others) if _same_points(_picks(b), picks, gate_px)]
            if not candidates:
                continue
            _, j = min(candidates)
            rows_a.append(picks.reshape(-1, 2))
            rows_b.append(_picks(others.pop(j)).reshape(-1, 2))
            pairs += 1
    if not pairs:
        return np.zeros((0, 2)), np.zeros((0, 2)), 0
    return np.concatenate(rows_a), np.concatenate(rows_b), pairs


def estimate_double_readings(project: ProjectStore, first: str, second: str,
                             gate_px: float = GATE_PX) -> tuple[PointingEstimate, str]:
    """The pointing σ of an annotator of the two (their mean variance) from their double readings, and what
    it came from in words."""
    a, b, pairs = double_read_points(project, first, second, gate_px)
    if not pairs:
        raise UsvipsError(f"{first} and {second} have measured no object on the same image (within {gate_px:g} px "
                          "of each other): nothing to compare")
    return from_double_readings(a, b), f"{pairs} objects double-read by {first} and {second}"


def tracked_runs(project: ProjectStore) -> tuple[list[np.ndarray], int]:
    """Every tracked vertex's pixels over runs of equally spaced frames (arrays (M, 2), left and right apart),
    from the objects with tracked instants, and how many such objects."""
    links = project.instant_links()
    sources = project.instant_sources()
    whole: dict[int, list[int]] = {}
    for instant, of in links.items():
        if sources.get(instant) is not None:
            whole.setdefault(of, []).append(instant)
    runs = []
    for object_id, instants in whole.items():
        stored = [project.object(i) for i in (object_id, *instants)]
        stored = [o for o in stored if o.vertices and o.vertices[0].frame_left is not None]
        stored.sort(key=lambda o: o.vertices[0].frame_left)
        if len(stored) < 3 or len({len(o.vertices) for o in stored}) > 1:
            continue
        picks = np.stack([_picks(o) for o in stored])
        for first, last in equal_steps([o.vertices[0].frame_left for o in stored]):
            if last - first >= 3:
                runs.extend(picks[first:last, i, side] for i in range(picks.shape[1]) for side in range(2))
    return runs, len(whole)


def equal_steps(frames: Sequence[int]) -> list[tuple[int, int]]:
    """The maximal runs [first, last) of increasing ``frames`` at one step each (neighbouring runs share
    their end frame); a step of 0 (the same frame twice) makes no run."""
    runs, start = [], 0
    for k in range(2, len(frames) + 1):
        if k == len(frames) or frames[k] - frames[k - 1] != frames[start + 1] - frames[start]:
            if frames[start + 1] > frames[start]:
                runs.append((start, k))
            start = k - 1
    return runs


def estimate_tracking(project: ProjectStore) -> tuple[PointingEstimate, str]:
    """The σ of tracked points about their tracks, and what it came from in words."""
    runs, objects = tracked_runs(project)
    if not runs:
        raise UsvipsError("no object has three tracked instants at equal steps: track an object over more frames")
    return from_tracks(runs), f"{objects} tracked objects"
