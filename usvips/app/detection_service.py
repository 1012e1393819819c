"""Detection in a project: a model's proposals found on an image pair or the frames of a stereo video,
paired through the housing, refined along the curve, measured, and stored as UNREVIEWED objects whose
source is the model.

Three steps, so that the window can run the middle one on its worker:

1. :func:`plan_detection` (the project's thread) reads what is needed: the calibration active for the
   pair or video, the images' paths or the video's files, the frames.
2. :func:`run_detection` (any thread) detects on left and right, pairs the detections by one assignment over
   the frame (:func:`usvips.core.detection.stereo.pair_detections`), refines each right keypoint along the
   left keypoint's refractive epipolar curve (:mod:`usvips.core.detection.refine`) and measures each pair's
   length with the model's MEASURED keypoint sigma (:func:`usvips.core.detection.stereo.measure_pairs`).
   A model without a measured sigma gives picks without a length (never an assumed sigma). It reports
   progress per frame and stops at a cancel (the frames done are kept).
3. :func:`store_proposals` (the project's thread) stores each proposal as a ``length`` object, unreviewed,
   created by ``model <name>``, each vertex's source ``keypoint (<point>, model <name> sha256:<12 hex>)``
   with its measured pointing sigma (origin "estimated"). A proposal without a length (its pair refused, or
   its measurement failed) carries the sigma its keypoints would have been measured with (``pointing``: the
   model's ``[stereo_sigma]`` by the fish's size, a right keypoint the model's own or following the left one
   as refinement left it), but stores it only with :data:`STORE_UNMEASURED_SIGMA` (off: see there).

Proposals never overwrite a person's object, nor repeat an object already there: a proposal whose snout and
fork lie, on the same pair (and left frame of a video), within a quarter of its pixel length of the two
ends of a stored object (either way round), or whose box holds a stored single-point object, is NOT
stored; it is reported as a duplicate of that object.

On a video, the proposals a run stores on successive looked-at frames that are the same fish are joined as
instants of one object (:mod:`usvips.app.detection_tracks`): the survey counts the fish once.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np

from usvips.app.detection_model import DetectionModel
from usvips.app.detection_tracks import JoinedFish, StoredSighting, fish_links, fish_of, link_instants
from usvips.app.pair_geometry import PairGeometry, pair_geometry
from usvips.app.video_project import left_frame_time, partner_frame
from usvips.core import validation
from usvips.core.detection import Detection
from usvips.core.detection.association import DEFAULT_MAX_SPEED_M_S
from usvips.core.detection.refine import RefinedPair, refine_pairs
from usvips.core.detection.stereo import MEASURED_KEYPOINT_SIGMA as SIGMA_MARK
from usvips.core.detection.stereo import StereoPair, measure_pairs, pair_detections
from usvips.core.errors import UsvipsError
from usvips.core.measurements.evaluate import Measurement
from usvips.core.pointing import RIGHT_FOLLOWS_LEFT, frame_correlation_qualifier
from usvips.io.images import read_image
from usvips.io.video_stream import PairReader, VideoStream
from usvips.store.interface import ProjectStore
from usvips.store.records import StoredObject, Vertex

#: the measured points of a proposal (a fork length)
KEYPOINTS = ("snout", "fork")
#: the pairing gate without a measured sigma (px): a threshold on the curve distance, no sigma claimed
DEFAULT_GATE_PX = 10.0
#: a proposal is the same fish as a stored object when both ends lie within this fraction of its length
SAME_FISH_FRACTION = 0.25
#: the largest factor between a pair's snout–fork lengths (px) in the two images when a right keypoint is the
#: model's own (not matched to the left one): beyond it one image's keypoints are not the fish's
MAX_UNMATCHED_LENGTH_RATIO = 1.5
#: whether a proposal WITHOUT a length is stored with the pointing sigma by the fish's size it would have been
#: measured with (:func:`with_model_sigma`), so that a reviewer who drags its wrong keypoint gets a length.
#: Not done: on rendered survey clips (docs/detection.md, "A corrected proposal's σ") such corrected lengths'
#: σ was conservative — NEES 0.43 (404 lengths) for a reviewer who moves each keypoint more than 2 px off —
#: outside 0.7–1.5, since the keypoints the reviewer left are better than the model's σ says
STORE_UNMEASURED_SIGMA = False
#: proposals stored (or instants linked) in one step of :func:`storing_proposals`: the window stores a run a
#: step a turn of its event loop (each proposal ~0.3 ms, each instant ~0.6 ms on its thread: issue 35 asks
#: for no freeze over 0.1 s, and a run over many frames finds hundreds)
STORE_STEP = 10


@dataclass(frozen=True)
class DetectionPlan:
    """What a run reads from the project: the pair or video ``label``, its geometry, the left frames to
    detect on (None: an image pair) with their right partners and times, and the image or video files."""

    label: str
    geometry: PairGeometry
    frames: tuple[int, ...] | None = None
    partners: tuple[int, ...] = ()
    left_paths: tuple[Path, ...] = ()
    right_paths: tuple[Path, ...] = ()
    project_path: str = ""

    @property
    def is_video(self) -> bool:
        return self.frames is not None

    @property
    def count(self) -> int:
        return 1 if self.frames is None else len(self.frames)

    def where(self, frame: int | None) -> str:
        return self.label if frame is None else f"{self.label} frame {frame}"


@dataclass(frozen=True)
class Proposal:
    """One proposed fish: where (``label``, left ``frame`` or None), its pair (refined), its measurement
    (None without a measured sigma, or the reason it failed in ``problem``), how many right keypoints were
    refined, and once stored its ``object_id`` — or ``duplicate_of`` the stored object it repeats — and
    ``instant_of``: the object (the same fish on an earlier frame) it was joined to as a further instant."""

    label: str
    frame: int | None
    pair: StereoPair
    measurement: Measurement | None
    refined: int
    problem: str = ""
    object_id: int | None = None
    duplicate_of: int | None = None
    instant_of: int | None = None
    #: for a proposal WITHOUT a length of a model with a ``[stereo_sigma]``: each keypoint's (left, right)
    #: pointing sigma (image px, by the fish's size: :func:`pair_pointing`) it would have been measured with
    #: (:func:`with_model_sigma`; stored only with :data:`STORE_UNMEASURED_SIGMA`); else ()
    pointing: tuple[tuple[float, float], ...] = ()
    #: with ``pointing``: whether each keypoint's right point was refined along the left one's curve (then it
    #: follows the left, :data:`usvips.core.pointing.RIGHT_FOLLOWS_LEFT`; else it is the model's own)
    right_follows: tuple[bool, ...] = ()

    def line(self) -> str:
        """One line for a person: where, the model's score, the pairing cost, the length with its sigma."""
        where = self.label if self.frame is None else f"{self.label} frame {self.frame}"
        what = (f"object {self.object_id}, instant of object {self.instant_of}" if self.instant_of is not None
                else f"object {self.object_id}" if self.object_id is not None
                else f"not stored: duplicate of object {self.duplicate_of}" if self.duplicate_of is not None
                else "not stored")
        if self.measurement is not None:
            main = self.measurement.main
            length = f"length {main.value * 1000:.1f} ± {main.sigma * 1000:.1f} mm"
        else:
            length = self.problem or "no length (no measured keypoint sigma)"
        return (f"{where}: {what}: {self.pair.left.class_name} score {self.pair.left.score:.2f}, pairing "
                f"{self.pair.cost_px:.2f} px, right keypoints refined {self.refined}/{len(KEYPOINTS)}, {length}")


@dataclass
class DetectionRun:
    """What a run found: its proposals, per frame the left and right detections and how many stayed
    unpaired, the frames done, whether it was cancelled, and once stored on a video the fish joined over
    its frames (``joined``)."""

    plan: DetectionPlan
    model: DetectionModel
    proposals: list[Proposal] = field(default_factory=list)
    detections: dict[int | None, tuple[tuple[Detection, ...], tuple[Detection, ...]]] = field(default_factory=dict)
    unpaired: int = 0
    frames_done: int = 0
    cancelled: bool = False
    joined: JoinedFish | None = None
    #: on a video, each proposal's left frame's time (s), read by the run (on the worker) so that storing does
    #: not open the video on the project's thread (None: read when stored)
    times: dict[int, float] | None = None

    def summary(self) -> list[str]:
        """Lines closing a run: what was looked at, found, stored, skipped, and the sigma used."""
        stored = sum(p.object_id is not None for p in self.proposals)
        duplicates = sum(p.duplicate_of is not None for p in self.proposals)
        measured = sum(p.measurement is not None for p in self.proposals)
        unit = "frame" if self.plan.is_video else "pair"
        lines = [f"{self.plan.label}: {self.frames_done} of {self.plan.count} {unit}(s) looked at"
                 f"{' (cancelled)' if self.cancelled else ''}; {len(self.proposals)} fish paired in both images, "
                 f"{self.unpaired} detection(s) unpaired; {stored} stored as unreviewed proposals, {duplicates} not "
                 f"stored (duplicates of stored objects); {measured} with a length",
                 self.model.sigma_line(KEYPOINTS)]
        if self.joined is not None:
            unmeasured = sum(p.object_id is not None and p.measurement is None for p in self.proposals)
            lines.insert(1, self.joined.line() + (f"; {unmeasured} proposal(s) without a length not joined"
                                                  if unmeasured else ""))
        return lines


def _geometry(project: ProjectStore, label: str) -> PairGeometry:
    geometry = pair_geometry(project, label)
    if geometry is None:
        raise UsvipsError(f"{label!r} has no active calibration: detections are paired through the housing, "
                          "which needs one (make a calibration active for it)")
    return geometry


def plan_detection(project: ProjectStore, pair: str | None = None, video: str | None = None, every: int = 1,
                   frames: tuple[int, int] | None = None) -> DetectionPlan:
    """What detecting on image pair ``pair`` — or on every ``every``-th left frame of video ``video`` from
    ``frames`` (first, last; inclusive; default the whole video) — needs; a pair, video or frame range the
    project does not have is a :class:`UsvipsError` naming it."""
    if (pair is None) == (video is None):
        raise UsvipsError("detect on one image pair or one video")
    if pair is not None:
        pairs = {p.label: p for p in project.pairs()}
        videos = {v.label for v in project.videos()}
        if pair in videos:
            raise UsvipsError(f"{pair!r} is a video, not an image pair: detect on its frames")
        if pair not in pairs:
            raise UsvipsError(f"the project has no image pair {pair!r}; it has: {', '.join(sorted(pairs)) or 'none'}")
        stored = pairs[pair]
        if stored.left is None or stored.right is None:
            raise UsvipsError(f"image pair {pair!r} has no image files")
        geometry = _geometry(project, pair)
        return DetectionPlan(pair, geometry, None, (), (project.media_location(stored.left),),
                             (project.media_location(stored.right),))
    videos = {v.label: v for v in project.videos()}
    if video not in videos:
        raise UsvipsError(f"the project has no video {video!r}; it has: {', '.join(sorted(videos)) or 'none'}")
    stored_video = videos[video]
    if int(every) < 1:
        raise UsvipsError(f"every: must be a whole number >= 1, got {every}")
    first, last = frames if frames is not None else (0, stored_video.frame_count - 1)
    if not 0 <= first <= last < stored_video.frame_count:
        raise UsvipsError(f"video {video!r}: frames {first}:{last} are not within 0:{stored_video.frame_count - 1}")
    geometry = _geometry(project, video)
    chosen, partners = [], []
    for frame in range(first, last + 1, int(every)):
        try:
            partners.append(partner_frame(stored_video, frame))
        except UsvipsError:
            continue  # a left frame without a right partner: nothing to pair
        chosen.append(frame)
    if not chosen:
        raise UsvipsError(f"video {video!r}: no left frame in {first}:{last} has a right partner")
    return DetectionPlan(video, geometry, tuple(chosen), tuple(partners),
                         tuple(project.media_path(p) for p in stored_video.paths("left")),
                         tuple(project.media_path(p) for p in stored_video.paths("right")))


def _bgr(image: np.ndarray) -> np.ndarray:
    """An image as the detector takes it: 8-bit BGR (or grey) from the RGB or grey, 8- or 16-bit files."""
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    return cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if image.ndim == 3 else image


def detect_frame(left: np.ndarray, right: np.ndarray, geometry: PairGeometry, model: DetectionModel,
                 detector=None, refine: bool = True,
                 gate_px: float | None = None) -> tuple[list[tuple[StereoPair, Measurement | None, int, str]],
                                                        tuple[Detection, ...], tuple[Detection, ...], int]:
    """One stereo frame (8-bit BGR or grey images): each fish paired in both images as (pair with refined
    right keypoints, its measurement or None, right keypoints refined, why there is no length), the left
    and right detections, and the number of detections left unpaired."""
    found, found_left, found_right, unpaired = _detect_frame(left, right, geometry, model, detector, refine, gate_px)
    return [(pair, m, count, why) for pair, m, count, why, _ in found], found_left, found_right, unpaired


def _detect_frame(left: np.ndarray, right: np.ndarray, geometry: PairGeometry, model: DetectionModel,
                  detector=None, refine: bool = True, gate_px: float | None = None):
    """:func:`detect_frame` with, per pair, a fifth item: for a pair without a length of a model with a
    ``[stereo_sigma]``, its keypoints' (sigmas (K, 2) px, refined flags (K,)) by :func:`pair_pointing`
    (what the pair knows: the fish's size, which right keypoints were refined); else None."""
    size = (left.shape[1], left.shape[0])
    sigmas = model.keypoint_sigma(KEYPOINTS, size)
    results, found_left, found_right, unpaired = pair_and_refine(left, right, geometry, model, detector, refine,
                                                                 gate_px)
    pairs = [result.pair for result in results]
    refined = [sum(k.refined for k in result.keypoints) for result in results]
    apart = [_disagreement(result) for result in results]
    measured: list = [None] * len(pairs)
    if sigmas is not None and pairs:
        chosen = [i for i, why in enumerate(apart) if not why]
        own = None
        if model.stereo_sigma(KEYPOINTS) is not None:
            own = [pair_pointing(model, pairs[i], _refined_flags(results[i]), (left.shape[1], left.shape[0]))
                   for i in chosen]
        lengths = measure_pairs([pairs[i] for i in chosen], geometry.calibration, sigmas, KEYPOINTS,
                                geometry.station, geometry.frame, measured_basis=model.sigma_basis(KEYPOINTS),
                                pair_pointing=own)
        for i, m in zip(chosen, lengths, strict=True):
            measured[i] = m
    stereo = sigmas is not None and model.stereo_sigma(KEYPOINTS) is not None
    out = []
    for result, m, count, why in zip(results, measured, refined, apart, strict=True):
        pair = result.pair
        if (why and sigmas is not None) or isinstance(m, UsvipsError):
            flags = _refined_flags(result)
            pointing = (pair_pointing(model, pair, flags, size)[0], flags) if stereo else None
            out.append((pair, None, count, f"no length: {why or m}", pointing))
        else:
            out.append((pair, m, count, "", None))
    return out, found_left, found_right, unpaired


def pair_and_refine(left: np.ndarray, right: np.ndarray, geometry: PairGeometry, model: DetectionModel,
                    detector=None, refine: bool = True, gate_px: float | None = None
                    ) -> tuple[list[RefinedPair], tuple[Detection, ...], tuple[Detection, ...], int]:
    """The first steps of :func:`detect_frame`: detect in both images, pair by one assignment over the frame
    (gated at ``gate_px``, else 4√2 × the model's larger measured keypoint sigma, else
    :data:`DEFAULT_GATE_PX`) and refine each right keypoint along the left one's curve (``refine``; else each
    pair as found, no keypoint refined). Returns the refined pairs, the left and right detections and the
    number of detections left unpaired."""
    detector = detector or model.make_detector()
    found_left, found_right = tuple(detector.detect(left)), tuple(detector.detect(right))
    rig = geometry.calibration.rig(geometry.station, geometry.frame)
    sigmas = model.keypoint_sigma(KEYPOINTS, (left.shape[1], left.shape[0]))
    gate = gate_px if gate_px is not None else (
        4 * math.sqrt(2) * max(sigmas.values()) if sigmas else DEFAULT_GATE_PX)
    pairing = pair_detections(found_left, found_right, rig, gate_px=gate, keypoints=KEYPOINTS)
    if refine:
        limits = shift_limits(model, pairing.pairs, (left.shape[1], left.shape[0]), sigmas)
        results = refine_pairs(left, right, pairing.pairs, rig, KEYPOINTS, radius_px=max(2 * gate, 8.0),
                               max_shift_px=limits)
    else:
        results = [RefinedPair(pair, ()) for pair in pairing.pairs]
    return results, found_left, found_right, len(pairing.unpaired_left) + len(pairing.unpaired_right)


def shift_limits(model: DetectionModel, pairs: Sequence[StereoPair], image_size: tuple[int, int],
                 sigmas: dict[str, float] | None) -> list[dict[str, float]] | dict[str, float] | None:
    """The largest move (image px) refinement may make to each pair's right keypoints: 3 standard deviations
    of the move the keypoints' own errors make — a larger one is a wrong match or a gross keypoint miss
    (refine's docstring), reached by honest errors in about 1 % of cases (the move is 2-D: a Rayleigh tail).
    With the model's ``[stereo_sigma]``, per pair by the fish's size: the move is the left keypoint's error
    carried over, plus the match's, minus the model's right keypoint's own (as the left's), so its σ per
    coordinate is √(2 σ_L(s)² + σ_m(s)²) — a fixed limit refused most fish over 100 px, whose keypoints err
    by more than the validated σ. Else 3√2 × the keypoint's one measured σ (one table for every pair);
    None without a measured σ (no limit)."""
    stereo = model.stereo_sigma(KEYPOINTS)
    if stereo is None:
        return {name: 3 * math.sqrt(2) * sigma for name, sigma in sigmas.items()} if sigmas else None
    scale = model.input_scale(image_size)
    out = []
    for pair in pairs:
        ends = np.array([pair.left.keypoint(k).pixel for k in KEYPOINTS])
        size = float(np.linalg.norm(ends[1] - ends[0]))
        out.append({k: 3.0 * math.sqrt(2 * (float(stereo.left[k](size * scale)) / scale) ** 2
                                       + float(stereo.match[k](size)) ** 2) for k in KEYPOINTS})
    return out


def pair_pointing(model: DetectionModel, pair: StereoPair, refined: Sequence[bool],
                  image_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """A pair's keypoints' pointing — sigmas (K, 2) image px [left, right] and left–right correlations (K,) —
    from the model's measured :class:`~usvips.core.detection.keypoint_sigma.StereoSigma`: by the fish's
    snout–fork length in the left image (the model's own keypoints), the refined right keypoints following
    the left ones (``refined``, per keypoint of :data:`KEYPOINTS`)."""
    ends = np.array([pair.left.keypoint(k).pixel for k in KEYPOINTS])
    return model.stereo_sigma(KEYPOINTS).pointing(KEYPOINTS, float(np.linalg.norm(ends[1] - ends[0])),
                                                  model.input_scale(image_size), refined)


def _refined_flags(result: RefinedPair) -> list[bool]:
    """Whether each keypoint of :data:`KEYPOINTS` was refined in the right image (False when not tried)."""
    done = {k.name: k.refined for k in result.keypoints}
    return [done.get(name, False) for name in KEYPOINTS]


def _disagreement(result: RefinedPair) -> str:
    """Why a refined pair's keypoints are not one point of the fish in both images ('' when they are): a
    keypoint whose match along the curve lay further from the model's right point than the model's measured
    sigma explains (:attr:`usvips.core.detection.refine.KeypointRefinement.beyond_limit`), or whose curve
    passes further from it than the search radius (``off_curve``). Such a pair's length would rest on a
    keypoint off by more than its sigma — on rendered fish such lengths erred by six times their sigma's
    variance (docs/detection.md, "Acceptance") — so it is given none, and a person places the points. So is
    a pair with a keypoint at either image's edge (``at_edge``): the fish may be cut by the frame (on
    rendered fish, a snout hidden beyond the edge gave a length 8.5 sigma short). And so is a pair with a
    right keypoint the model's own whose lengths in the two images differ too much (:func:`_unmatched_lengths`)."""
    reasons = ([f"the {k.name}s in the two images are not one point ({k.reason})" for k in result.keypoints
                if k.beyond_limit or k.off_curve]
               + [f"the {k.name} is {k.reason} (the fish may be cut by the frame)" for k in result.keypoints
                  if k.at_edge])
    return "; ".join(reasons) or _unmatched_lengths(result)


def _unmatched_lengths(result: RefinedPair) -> str:
    """Why a pair whose right keypoints are not all matched to the left ones is no one fish ('' when it may
    be): its snout–fork lengths in the two images differ by more than :data:`MAX_UNMATCHED_LENGTH_RATIO`.
    A matched right keypoint follows the left one; an unmatched one is the model's own. On the rendered
    survey clips of the model's [stereo_sigma] fit (381 lengths) the 7 pairs with an unmatched keypoint whose
    lengths differed so all had one image's keypoints off the fish (lengths 3–24σ off, or of no fish); none of
    the 367 pairs of one fish did (docs/detection.md, "Lengths of no fish")."""
    done = {k.name: k.refined for k in result.keypoints}
    if all(done.get(name, False) for name in KEYPOINTS):
        return ""
    lengths = [float(np.linalg.norm(np.subtract(*(side.keypoint(k).pixel for k in KEYPOINTS))))
               for side in (result.pair.left, result.pair.right)]
    if min(lengths) <= 0 or max(lengths) <= MAX_UNMATCHED_LENGTH_RATIO * min(lengths):
        return ""
    return (f"its snout–fork lengths in the two images, {lengths[0]:.0f} px and {lengths[1]:.0f} px, differ by more "
            f"than {MAX_UNMATCHED_LENGTH_RATIO:g} × with a right keypoint the model's own: one image's keypoints "
            "are not the fish's")


def _frames(plan: DetectionPlan):
    """(left frame or None, left image, right image) of each frame of the plan, decoded lazily."""
    if not plan.is_video:
        yield None, _bgr(read_image(plan.left_paths[0])), _bgr(read_image(plan.right_paths[0]))
        return
    left, right = VideoStream(list(plan.left_paths)), VideoStream(list(plan.right_paths))
    reader = PairReader(left, right)
    try:
        for frame, partner in zip(plan.frames, plan.partners, strict=True):
            pictures = reader.pictures(frame, partner)
            yield frame, *(cv2.cvtColor(p.array(), cv2.COLOR_RGB2BGR) for p in pictures)
    finally:
        reader.close()
        left.close()
        right.close()


def run_detection(plan: DetectionPlan, model: DetectionModel, cancel: Callable[[], bool] | None = None,
                  progress: Callable[[int, int], None] | None = None, refine: bool = True,
                  gate_px: float | None = None) -> DetectionRun:
    """Detect, pair, refine and measure on every frame of ``plan`` (any thread; reads no project), with
    ``progress(done, total)`` after each frame and ``cancel()`` checked before each (the frames done are
    kept)."""
    run = DetectionRun(plan, model)
    detector = model.make_detector()
    frames = _frames(plan)
    try:
        for frame, left, right in frames:
            if cancel is not None and cancel():
                run.cancelled = True
                break
            found, seen_left, seen_right, unpaired = _detect_frame(left, right, plan.geometry, model, detector,
                                                                   refine, gate_px)
            run.detections[frame] = (seen_left, seen_right)
            run.unpaired += unpaired
            run.proposals.extend(Proposal(plan.label, frame, pair, m, count, problem, **_stated(pointing))
                                 for pair, m, count, problem, pointing in found)
            run.frames_done += 1
            if progress is not None:
                progress(run.frames_done, plan.count)
    finally:
        frames.close()
    if plan.is_video:
        run.times = _times(plan, sorted({p.frame for p in run.proposals if p.frame is not None}))
    return run


def _stated(pointing: tuple[np.ndarray, Sequence[bool]] | None) -> dict:
    """A proposal's ``pointing`` and ``right_follows`` fields from :func:`_detect_frame`'s fifth item."""
    if pointing is None:
        return {}
    sigmas, flags = pointing
    return {"pointing": tuple((float(a), float(b)) for a, b in np.asarray(sigmas, dtype=np.float64)),
            "right_follows": tuple(bool(f) for f in flags)}


def _same_fish(proposal: Proposal, stored: StoredObject) -> bool:
    ends = np.array([proposal.pair.left.keypoint(k).pixel for k in KEYPOINTS])
    points = np.array([(v.xl, v.yl) for v in stored.vertices])
    if len(points) == 1:
        x0, y0, x1, y1 = proposal.pair.left.box
        return bool(x0 <= points[0, 0] <= x1 and y0 <= points[0, 1] <= y1)
    tolerance = SAME_FISH_FRACTION * max(float(np.linalg.norm(ends[1] - ends[0])), 1.0)
    pair_ends = points[[0, -1]]
    return bool(np.all(np.linalg.norm(pair_ends - ends, axis=1) <= tolerance)
                or np.all(np.linalg.norm(pair_ends[::-1] - ends, axis=1) <= tolerance))


def _on(stored: StoredObject, label: str, frame: int | None) -> bool:
    if not stored.vertices or stored.vertices[0].pair != label:
        return False
    return frame is None or stored.vertices[0].frame_left == frame


def source_label(point: str, model: DetectionModel, right_follows: bool = False, measured: bool = False) -> str:
    """The stored source of a proposal's vertex: ``keypoint (<point>, model <name> sha256:<12 hex>)``, and
    ``, right matched to left`` when its right point was refined along the left one's curve (measured so, or
    given the sigma it would be measured with, :func:`with_model_sigma`: :data:`usvips.core.pointing.
    RIGHT_FOLLOWS_LEFT`: the object's figure, recomputed from its picks, then keeps the left and right errors
    correlated); for a ``measured`` proposal of a model whose frame correlation was measured,
    ``, frame correlation <ρ>`` (:data:`usvips.core.pointing.FRAME_CORRELATION`: the object's figure combined
    over its frames keeps that share of their pointing errors whole)."""
    qualifiers = [f"model {model.tag}"] + ([RIGHT_FOLLOWS_LEFT] if right_follows else [])
    correlation = model.description.frame_correlation
    if measured and correlation is not None:
        qualifiers.append(frame_correlation_qualifier(correlation))
    return f"keypoint ({point}, {', '.join(qualifiers)})"


def proposal_vertices(proposal: Proposal, plan: DetectionPlan, model: DetectionModel,
                      times: dict[int, float]) -> list[Vertex]:
    """The vertices a proposal is stored as (snout, fork), with their 3-D points and covariance when it has
    a length, the model's measured sigma, and on a video its frames and time. A proposal without a length
    keeps the model's one measured sigma per keypoint, if any; the sigma by the fish's size it would have
    been measured with (its ``pointing``) only with :data:`STORE_UNMEASURED_SIGMA` (see there)."""
    m = proposal.measurement
    frame = proposal.frame
    partner = None if frame is None else plan.partners[plan.frames.index(frame)]
    vertices = []
    if m is not None:
        follows = (m.pointing_correlation > 0 if m.pointing_correlation is not None
                   else np.zeros(len(KEYPOINTS), dtype=bool))
    else:
        follows = np.zeros(len(KEYPOINTS), dtype=bool)
    for i, name in enumerate(KEYPOINTS):
        left, right = proposal.pair.left.keypoint(name), proposal.pair.right.keypoint(name)
        sigma = _vertex_sigma(m, i) if m is not None else model.description.measured_sigma(name)
        xyz = tuple(map(float, m.points[i])) if m is not None else None
        covariance = m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] if m is not None else None
        vertices.append(Vertex(float(left.x), float(left.y), float(right.x), float(right.y), xyz, covariance,
                               plan.geometry.calibration_id if m is not None else None, plan.label,
                               plan.label if frame is not None else None, frame, partner,
                               times.get(frame) if frame is not None else None,
                               source=source_label(name, model, bool(follows[i]), m is not None),
                               pointing_px=sigma if sigma is None or isinstance(sigma, tuple) else (sigma, sigma),
                               pointing_origin="estimated" if sigma is not None else "default"))
    if m is None and proposal.pointing and STORE_UNMEASURED_SIGMA:
        return with_model_sigma(vertices, proposal, model)
    return vertices


def with_model_sigma(vertices: Sequence[Vertex], proposal: Proposal, model: DetectionModel) -> list[Vertex]:
    """A stored proposal without a length's ``vertices`` (snout, fork) with the pointing sigma its keypoints
    would have been measured with (``proposal.pointing``: the model's ``[stereo_sigma]`` by the fish's size)
    and sources that say which right keypoints follow the left ones — what a reviewer's correction
    (:func:`usvips.app.proposal_correction.corrected_vertices`) then measures with. Unchanged when the
    proposal carries no such sigma."""
    if not proposal.pointing:
        return list(vertices)
    return [replace(v, pointing_px=tuple(map(float, proposal.pointing[i])), pointing_origin="estimated",
                    source=source_label(name, model, bool(proposal.right_follows[i])))
            for i, (v, name) in enumerate(zip(vertices, KEYPOINTS, strict=True))]


def _vertex_sigma(measurement: Measurement, vertex: int) -> tuple[float, float] | None:
    """The (left, right) pointing sigma (px) the proposal's length was measured with at ``vertex``: stored
    with the vertex, so that the object's figure, recomputed from its picks, is the proposal's (the model's
    validated sigma is scaled to the frame's pixels, which the description's table alone does not say)."""
    if measurement.pointing_sigma_px is None:
        return None
    left, right = np.asarray(measurement.pointing_sigma_px, dtype=np.float64).reshape(-1, 2)[vertex]
    return float(left), float(right)


def proposal_note(proposal: Proposal, model: DetectionModel) -> str:
    """The stored proposal's notes: the model, its score, the pairing, the refinement, and what its length's
    keypoint sigma rests on (the object's figure, recomputed from its picks, carries the sigma but not its
    basis) — or why it has no length."""
    measured = proposal.measurement
    basis = next((mark for mark in measured.marks if mark.startswith(SIGMA_MARK)), "") if measured else ""
    why = basis or proposal.problem
    return (f"proposed by model {model.tag}: score {proposal.pair.left.score:.2f}, pairing "
            f"{proposal.pair.cost_px:.2f} px, right keypoints refined {proposal.refined}/{len(KEYPOINTS)}"
            + (f"; {why}" if why else ""))


def _times(plan: DetectionPlan, frames: Sequence[int]) -> dict[int, float]:
    if not frames:
        return {}
    with VideoStream(list(plan.left_paths)) as left:
        return {f: left_frame_time(left, f) for f in frames}


def store_proposals(project: ProjectStore, run: DetectionRun,
                    max_speed_m_s: float = DEFAULT_MAX_SPEED_M_S) -> DetectionRun:
    """Store the run's proposals as unreviewed ``length`` objects made by the model (one transaction), each
    one not already there (see the module docstring: a duplicate is reported, never stored); fills in each
    proposal's ``object_id`` or ``duplicate_of``. On a video, the stored proposals of one fish on successive
    frames are then joined as instants of one object (``max_speed_m_s``: the fastest a fish is taken to
    swim, :mod:`usvips.app.detection_tracks`; one more transaction), filling in ``instant_of`` and the run's
    ``joined``. (:func:`storing_proposals` with every proposal in one step.)"""
    for _ in storing_proposals(project, run, max_speed_m_s, per_step=max(len(run.proposals), 1)):
        pass
    return run


@dataclass(frozen=True)
class StoringStep:
    """What one step of :func:`storing_proposals` stored: the objects it ``added`` (proposals), or the
    ``links`` it made, each (further instant, the object it is an instant of)."""

    added: tuple[int, ...] = ()
    links: tuple[tuple[int, int], ...] = ()

    @property
    def changed(self) -> tuple[int, ...]:
        """The stored objects the links changed (each instant and its object), by id."""
        return tuple(sorted({i for link in self.links for i in link}))


def storing_proposals(project: ProjectStore, run: DetectionRun, max_speed_m_s: float = DEFAULT_MAX_SPEED_M_S,
                      per_step: int = STORE_STEP) -> Iterator[StoringStep]:
    """:func:`store_proposals` a slice at a time, for a caller that must answer between slices (the window's
    thread, the project's): each step — one ``next`` — stores at most ``per_step`` proposals (one transaction),
    then each further step links at most ``per_step`` instants of the fish joined (one transaction), and yields
    what it stored (a window tells its views of it before the next turn of its event loop: else its feed of
    colleagues' changes would take them for a colleague's). Once exhausted, the run is as
    :func:`store_proposals` leaves it (the same objects, duplicates and instants); stopped part-way, the
    slices done are stored and the rest are not."""
    max_speed_m_s = validation.positive("max_speed", max_speed_m_s)
    per_step = validation.count("per_step", per_step, 1, 10**9)
    plan, model = run.plan, run.model
    frames = sorted({p.frame for p in run.proposals if p.frame is not None})
    existing = (project.objects_on(plan.label, frames[0], frames[-1]) if frames  # (not a whole survey read)
                else project.objects_on(plan.label))
    times = run.times if run.times is not None else _times(plan, frames)
    for begin in range(0, len(run.proposals), per_step):
        rows, where = [], []
        for i in range(begin, min(begin + per_step, len(run.proposals))):
            proposal = run.proposals[i]
            twin = next((o for o in existing if _on(o, plan.label, proposal.frame) and _same_fish(proposal, o)), None)
            if twin is not None:
                run.proposals[i] = _with(proposal, duplicate_of=twin.id)
                continue
            rows.append(("length", proposal_vertices(proposal, plan, model, times), "",
                         proposal_note(proposal, model), f"model {model.name}"))
            where.append(i)
        if rows:
            ids = project.add_objects(rows)  # (one transaction)
            for i, object_id in zip(where, ids, strict=True):
                run.proposals[i] = _with(run.proposals[i], object_id=object_id)
        yield StoringStep(added=tuple(run.proposals[i].object_id for i in where))
    if plan.is_video:
        yield from _joining(project, run, times, max_speed_m_s, per_step)


def _joining(project: ProjectStore, run: DetectionRun, times: dict[int, float], max_speed_m_s: float,
             per_step: int) -> Iterator[StoringStep]:
    """Join the run's stored, measured proposals into fish (instants of one object each), linking at most
    ``per_step`` instants a step (one transaction each; a fish with more is linked over several)."""
    chosen = [i for i, p in enumerate(run.proposals) if p.object_id is not None and p.measurement is not None]
    stored = [StoredSighting(run.proposals[i].object_id, run.proposals[i].frame, times[run.proposals[i].frame],
                             run.proposals[i].measurement) for i in chosen]
    found = fish_of(stored, run.plan.frames[:run.frames_done], max_speed_m_s)
    links = fish_links(stored, found)
    pairs = [(whole, instant) for whole, rest in links for instant in rest]
    for begin in range(0, len(pairs), per_step):
        step: dict[int, list[int]] = {}
        for whole, instant in pairs[begin:begin + per_step]:
            step.setdefault(whole, []).append(instant)
        link_instants(project, list(step.items()))
        yield StoringStep(links=tuple((instant, whole) for whole, instant in pairs[begin:begin + per_step]))
    run.joined = JoinedFish(tuple(links), found.ambiguous, float(max_speed_m_s))
    whole_of = {instant: whole for whole, rest in links for instant in rest}
    for i in chosen:
        whole = whole_of.get(run.proposals[i].object_id)
        if whole is not None:
            run.proposals[i] = _with(run.proposals[i], instant_of=whole)


def _with(proposal: Proposal, **changes) -> Proposal:
    return replace(proposal, **changes)


def detect_in_project(project: ProjectStore, model: DetectionModel, pair: str | None = None,
                      video: str | None = None, every: int = 1, frames: tuple[int, int] | None = None,
                      cancel: Callable[[], bool] | None = None, progress: Callable[[int, int], None] | None = None,
                      refine: bool = True, max_speed_m_s: float = DEFAULT_MAX_SPEED_M_S) -> DetectionRun:
    """:func:`plan_detection`, :func:`run_detection` and :func:`store_proposals` in one go (the command line)."""
    max_speed_m_s = validation.positive("max_speed", max_speed_m_s)
    plan = plan_detection(project, pair, video, every, frames)
    return store_proposals(project, run_detection(plan, model, cancel, progress, refine), max_speed_m_s)
