"""How honest the σ of a corrected proposal is, measured: proposals stored WITHOUT a length (their pair
refused: a match beyond its limit, a keypoint at the edge, lengths that differ in the two images…), given
the pointing σ by the fish's size they would have been measured with
(:func:`usvips.app.detection_service.with_model_sigma`), on rendered stereo survey clips with truth,
corrected by a simulated reviewer as the window's drag corrects
them (:func:`usvips.app.proposal_correction.corrected_vertices`), and the corrected lengths scored against
the true lengths.

Each clip (:func:`usvips.core.synth.stereo_survey.survey_clip`) is written into a project and detected on as
``usvips detect`` does (:func:`usvips.app.detection_acceptance.write_clip_project`,
:func:`usvips.app.detection_service.detect_in_project`). A stored proposal without a length is scored when it
is ONE true fish — its left and right detections the same fish by the acceptance's rule
(:func:`usvips.app.detection_acceptance.assign`) — that a reviewer can measure: the fish
:attr:`~usvips.core.synth.fish_scene.FishTruth.required` in both images (snout and fork visible, half of it
unhidden, 20 px or more long). The reviewer (:class:`Reviewer`) moves each keypoint, in each image, that lies
further than a threshold from the true point to the true point plus a click error drawn from a Student-t
(heavy-tailed) of a given RMS per coordinate, and leaves the others as the model put them. A proposal with no
keypoint so far off is counted apart (``untouched``: the reviewer sees nothing to move, and it stays without
a length). The corrected object is measured as the object list measures it
(:func:`usvips.app.project_figures.evaluate` of its :func:`~usvips.app.project_figures.measurement_input`):
its normalised error (length − true length) / σ, the NEES and the share within 2σ.

Metres and pixels; truth from the renderer (the figures say how honest the σ is on rendered fish).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from usvips.app.detection_acceptance import _ends, assign, write_clip_project
from usvips.app.detection_model import DetectionModel
from usvips.app.detection_service import KEYPOINTS, detect_in_project, with_model_sigma
from usvips.app.project_figures import evaluate, measurement_input
from usvips.app.proposal_correction import corrected_vertices
from usvips.core.errors import UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import vertex_correlation
from usvips.core.synth.stereo_survey import survey_clip
from usvips.store.opening import open_project

#: a circle of this many σ (per coordinate) around a keypoint holds its true point with 95 % probability
CIRCLE_SIGMAS = math.sqrt(-2.0 * math.log(0.05))


@dataclass(frozen=True)
class Reviewer:
    """A simulated reviewer: moves a keypoint whose true point lies more than ``threshold_px`` away (image px;
    with ``circle``, more than the larger of that and the keypoint's 95 % circle, :data:`CIRCLE_SIGMAS` × its
    stored σ — what the window draws) to the true point plus a click error per coordinate drawn from a
    Student-t of ``click_dof`` degrees of freedom scaled to an RMS of ``click_rms_px`` (a normal one when
    ``click_dof`` is infinite)."""

    name: str
    threshold_px: float = 2.0
    click_rms_px: float = 0.6
    click_dof: float = 5.0
    circle: bool = False

    def click(self, rng: np.random.Generator) -> np.ndarray:
        """One click's error (2,) px."""
        if not math.isfinite(self.click_dof):
            return rng.normal(0.0, self.click_rms_px, 2)
        return rng.standard_t(self.click_dof, 2) * self.click_rms_px / math.sqrt(self.click_dof / (self.click_dof - 2))

    def limit(self, sigma_px: float | None) -> float:
        """How far off (px) a keypoint of pointing σ ``sigma_px`` must be for this reviewer to move it."""
        if self.circle and sigma_px is not None:
            return max(self.threshold_px, CIRCLE_SIGMAS * sigma_px)
        return self.threshold_px


#: the reviewers of the report: the main one (2 px, t₅ clicks of 0.6 px RMS — the window stores 0.5 px) and
#: variants of its threshold and hand
REVIEWERS = (Reviewer("2 px, t5 clicks 0.6 px"), Reviewer("1 px, t5 clicks 0.6 px", threshold_px=1.0),
             Reviewer("3 px, t5 clicks 0.6 px", threshold_px=3.0),
             Reviewer("95 % circle (>= 1 px), t5 clicks 0.6 px", threshold_px=1.0, circle=True),
             Reviewer("2 px, t5 clicks 1.0 px", click_rms_px=1.0),
             Reviewer("2 px, normal clicks 0.5 px", click_rms_px=0.5, click_dof=math.inf))


@dataclass
class CorrectionFigures:
    """Per reviewer: the normalised errors of the corrected lengths, the proposals left untouched, the
    keypoints moved; and over the run the clips, the proposals without a length, and those scored (one true
    fish a reviewer can measure), with each scored one's reason for having no length."""

    clips: int = 0
    lacking: int = 0
    scored: int = 0
    reasons: list[str] = field(default_factory=list)
    errors: dict[str, list[float]] = field(default_factory=dict)
    #: per reviewer, the reason (of :attr:`reasons`' kinds) of each of its ``errors``
    error_reasons: dict[str, list[str]] = field(default_factory=dict)
    #: each scored proposal's length as the model proposed it (no correction), measured with its stored σ:
    #: what the refusal kept out (its normalised errors, by reason)
    as_proposed: list[float] = field(default_factory=list)
    as_proposed_reasons: list[str] = field(default_factory=list)
    untouched: dict[str, int] = field(default_factory=dict)
    moved: dict[str, int] = field(default_factory=dict)
    failed: dict[str, int] = field(default_factory=dict)

    def summary(self) -> dict:
        out = {"clips": self.clips, "proposals_without_length": self.lacking, "one_true_fish": self.scored,
               "reasons": {r: self.reasons.count(r) for r in sorted(set(self.reasons))}, "reviewers": {}}
        for name, z in self.errors.items():
            values = np.asarray(z, dtype=np.float64)
            out["reviewers"][name] = {
                "lengths": len(values), "untouched": self.untouched.get(name, 0),
                "keypoints_moved": self.moved.get(name, 0), "failed": self.failed.get(name, 0),
                "nees": round(float(np.mean(values ** 2)), 3) if len(values) else None,
                "within_2sigma": round(float(np.mean(np.abs(values) <= 2)), 3) if len(values) else None,
                "median_abs_z": round(float(np.median(np.abs(values))), 3) if len(values) else None,
                "by_reason": _by_reason(values, self.error_reasons.get(name, []))}
        out["as_proposed"] = _by_reason(np.asarray(self.as_proposed, dtype=np.float64), self.as_proposed_reasons)
        return out


def _by_reason(values: np.ndarray, reasons: Sequence[str]) -> dict:
    """NEES, share within 2σ and count of normalised errors ``values``, over all and per reason."""
    out = {}
    for key in ["all", *sorted(set(reasons))]:
        chosen = values if key == "all" else values[np.array([r == key for r in reasons], dtype=bool)]
        if len(chosen):
            out[key] = {"n": len(chosen), "nees": round(float(np.mean(chosen ** 2)), 3),
                        "within_2sigma": round(float(np.mean(np.abs(chosen) <= 2)), 3)}
    return out


def _reason(problem: str) -> str:
    """The kind of refusal a proposal's problem states (for the breakdown)."""
    for key, words in (("beyond limit", "the match would move it"), ("at edge", "at the image's edge"),
                       ("off curve", "epipolar curve passes"), ("lengths differ", "differ by more than")):
        if words in problem:
            return key
    return "other"


def correct(stored, truth_left: np.ndarray, truth_right: np.ndarray, geometry, reviewer: Reviewer,
            rng: np.random.Generator) -> tuple[list, int]:
    """The vertices of ``stored`` after ``reviewer`` moved its keypoints off their true points (``truth_left``,
    ``truth_right``: (K, 2) px, snout and fork), and how many it moved."""
    vertices, moved = list(stored.vertices), 0
    for index in range(len(vertices)):
        for side, truth in (("left", truth_left), ("right", truth_right)):
            v = vertices[index]
            at = np.array([v.xl, v.yl] if side == "left" else [v.xr, v.yr])
            sigma = None if v.pointing_px is None else v.pointing_px[0 if side == "left" else 1]
            if np.linalg.norm(at - truth[index]) > reviewer.limit(sigma):
                click = truth[index] + reviewer.click(rng)
                vertices = corrected_vertices(replace(stored, vertices=vertices), index, side, tuple(click),
                                              geometry, "reviewer")
                moved += 1
    return vertices, moved


def measure_corrections(model: DetectionModel, seeds: Iterable[int], folder: Path,
                        reviewers: Sequence[Reviewer] = REVIEWERS, size: tuple[int, int] = (640, 480),
                        frames: int = 4, step: int = 2, chunk: int = 8, cpu_budget_s: float | None = None,
                        progress: Callable[[str], None] | None = None,
                        figures: CorrectionFigures | None = None) -> CorrectionFigures:
    """Render a clip per seed, detect on it as ``usvips detect`` does (``chunk`` clips per project in
    ``folder``), correct each scored proposal without a length by every one of ``reviewers`` (the same click
    draws for each, seeded by the clip) and score the corrected lengths (see the module docstring). Stops
    after the chunk that passes ``cpu_budget_s`` of CPU time, if given. ``figures``: added to (a new one when
    None)."""
    figures = figures if figures is not None else CorrectionFigures(errors={r.name: [] for r in reviewers})
    seeds = list(seeds)
    start = time.process_time()
    for first in range(0, len(seeds), chunk):
        batch = seeds[first:first + chunk]
        clips = [survey_clip(int(seed), size, frames, 25.0, step) for seed in batch]
        path = write_clip_project(folder / f"chunk{first}", clips)
        with open_project(path) as project:
            for i, (seed, clip) in enumerate(zip(batch, clips, strict=True)):
                run = detect_in_project(project, model, video=f"clip{i}")
                figures.clips += 1
                _score(project, run, clip, int(seed), reviewers, figures)
        if progress is not None:
            progress(f"{figures.clips} clips, {figures.scored} scored of {figures.lacking} without a length, "
                     f"{time.process_time() - start:.0f} s CPU")
        if cpu_budget_s is not None and time.process_time() - start > cpu_budget_s:
            break
    return figures


def _score(project, run, clip, seed: int, reviewers: Sequence[Reviewer], figures: CorrectionFigures) -> None:
    geometry = run.plan.geometry
    for k, proposal in enumerate(run.proposals):
        if proposal.object_id is None or proposal.measurement is not None:
            continue
        figures.lacking += 1
        frame = clip.frames[proposal.frame]
        left = assign(_ends(proposal.pair.left)[None], frame.left_truth)[0]
        right = assign(_ends(proposal.pair.right)[None], frame.right_truth)[0]
        if left is None or left != right or not (frame.left_truth[left].required and
                                                 frame.right_truth[left].required):
            continue
        figures.scored += 1
        figures.reasons.append(_reason(proposal.problem))
        stored = project.object(proposal.object_id)
        stored = replace(stored, vertices=with_model_sigma(stored.vertices, proposal, run.model))
        truth_left = frame.left_truth[left].keypoints[:len(KEYPOINTS)]
        truth_right = frame.right_truth[left].keypoints[:len(KEYPOINTS)]
        length = frame.left_truth[left].length
        proposed = _as_proposed(stored, geometry)
        if proposed is not None:
            figures.as_proposed.append((proposed.main.value - length) / proposed.main.sigma)
            figures.as_proposed_reasons.append(figures.reasons[-1])
        for reviewer in reviewers:
            rng = np.random.default_rng([seed, k])
            vertices, moved = correct(stored, truth_left, truth_right, geometry, reviewer, rng)
            figures.moved[reviewer.name] = figures.moved.get(reviewer.name, 0) + moved
            if not moved:
                figures.untouched[reviewer.name] = figures.untouched.get(reviewer.name, 0) + 1
                continue
            try:
                measured = evaluate(measurement_input(project, replace(stored, vertices=vertices),
                                                      with_instants=False))
            except UsvipsError:
                figures.failed[reviewer.name] = figures.failed.get(reviewer.name, 0) + 1
                continue
            figures.errors[reviewer.name].append((measured.main.value - length) / measured.main.sigma)
            figures.error_reasons.setdefault(reviewer.name, []).append(figures.reasons[-1])


def _as_proposed(stored, geometry):
    """The proposal's length with its stored σ, as the model proposed it (None when it has no σ or fails)."""
    if any(v.pointing_px is None for v in stored.vertices):
        return None
    left = np.array([(v.xl, v.yl) for v in stored.vertices])
    right = np.array([(v.xr, v.yr) for v in stored.vertices])
    sigmas = np.array([v.pointing_px for v in stored.vertices], dtype=np.float64)
    try:
        return measure_picks(stored.kind, geometry.calibration, left, right, geometry.station, geometry.frame,
                             pointing_sigma_px=sigmas,
                             pointing_correlation=vertex_correlation([v.source for v in stored.vertices], sigmas))
    except UsvipsError:
        return None


def main(argv: Sequence[str] | None = None) -> None:
    """``python -m usvips.training.correction_honesty FIRST_SEED COUNT FOLDER [CPU_BUDGET_S]``: the run of the
    report with the shipped model, its summary printed as JSON."""
    import json
    import sys

    from usvips.app.detection_model import bundled_model_path, load_model

    args = list(sys.argv[1:] if argv is None else argv)
    first, count, folder = int(args[0]), int(args[1]), Path(args[2])
    budget = float(args[3]) if len(args) > 3 else None
    figures = CorrectionFigures(errors={r.name: [] for r in REVIEWERS})
    try:
        measure_corrections(load_model(bundled_model_path()), range(first, first + count), folder,
                            cpu_budget_s=budget, progress=lambda line: print(line, flush=True), figures=figures)
    finally:
        print(json.dumps(figures.summary(), indent=1), flush=True)


if __name__ == "__main__":
    main()
