"""Calibrating a rig from views of a calibration target (a board or a 3-D target field): the one service the
command line (``usvips calibrate air|water --target … --images …|--video …``) and the window's target path
share.

1. **Views**: the target found in image pairs (:func:`views_from_images`, over
   :func:`usvips.app.target_views.detect_views`) or in a project's stereo video
   (:func:`views_from_video`, over :func:`usvips.app.calibration_video.scan_video`), with the coverage of the
   views found and its advice. Long work: ``progress(fraction, message)`` after each image or instant, and
   ``cancel`` (a :class:`threading.Event` or a callable returning True) checked before each one; a cancel
   raises :class:`InterruptedError` there.
2. **Calibration** (:func:`calibrate_views`): the views the user kept → stereo observations → phase 1 in
   air (:func:`~usvips.core.calibration.calibrate_air`) or phase 2 underwater through a housing from a
   phase-1 base (:func:`~usvips.core.calibration.calibrate_water`; several views = one joint adjustment),
   optionally validated on held-out views (:func:`~usvips.core.calibration.validation.validate`). A
   printed board's geometry is taken as exact (``CalibrationOptions.control_exact``).

Nothing here writes to a project: the caller stores the result (:func:`store`) only once it is converged,
so a failure leaves the project as it was.

Conventions: pixels x right, y down, origin at the centre of the top-left pixel; metres; radians.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvips.app.calibration_video import DEFAULT_MAX_VIEWS, read_target, scan_streams, scan_video
from usvips.app.calibrations import store_calibration
from usvips.app.target_views import detect_views
from usvips.core import calibration_views
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.phases import CalibrationResult, observes_a_plane, require_physical
from usvips.core.calibration.validation import Validation, validate
from usvips.core.calibration_targets import CalibrationTarget, StereoView, stereo_observations
from usvips.core.calibration_views import Coverage
from usvips.core.errors import ConvergenceError, DegenerateGeometryError, InvalidParameterError, UsvipsError
from usvips.core.observations import StereoObservations
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.video_stream import VideoStream
from usvips.store.interface import ProjectStore

Progress = Callable[[float, str], None]
Cancel = threading.Event | Callable[[], bool]

#: the phases a board calibrates
PHASES = ("air", "water")

#: views set aside listed one per line by :meth:`BoardViews.lines` (a video's thousands of instants are
#: counted beyond)
SET_ASIDE_LINES = 40

#: views a calibration needs at least (a board's planar start needs several orientations)
MINIMUM_VIEWS = 3


@dataclass(frozen=True)
class BoardViews:
    """Views of the target found in one source.

    ``views``: the usable ones (each a :class:`StereoView`: its label, both cameras' detections and where
    it came from); ``set_aside``: (label, one line why) for the pairs or instants not usable; ``coverage``:
    what the views cover per camera and the advice; ``tally``: lines counting what was looked at."""

    views: tuple[StereoView, ...]
    set_aside: tuple[tuple[str, str], ...]
    coverage: Coverage
    tally: tuple[str, ...]

    def image_size(self) -> tuple[int, int]:
        """(width, height) of the left images (pixels)."""
        return tuple(self.views[0].left.image_size)

    def lines(self, most: int = SET_ASIDE_LINES) -> list[str]:
        """For a person: the tally, each view set aside (the first ``most``, then how many more), then the
        coverage and its advice."""
        aside = [reason for _, reason in self.set_aside]
        if len(aside) > most:
            aside = aside[:most] + [f"… and {len(aside) - most} more set aside"]
        return list(self.tally) + aside + self.coverage.summary()


def _is_cancelled(cancel: Cancel | None) -> bool:
    if cancel is None:
        return False
    if isinstance(cancel, threading.Event):
        return cancel.is_set()
    return bool(cancel())


def as_target(target: CalibrationTarget | str | Path) -> CalibrationTarget:
    """A target, or the target described in a JSON file (errors name the file)."""
    return target if isinstance(target, CalibrationTarget) else read_target(target)


def _coverage(views: Sequence[StereoView], target: CalibrationTarget) -> Coverage:
    return calibration_views.coverage(list(views), target.control_points())


def views_from_images(target: CalibrationTarget | str | Path, pairs: Sequence[tuple[str | Path, str | Path]],
                      labels: Sequence[str] | None = None, progress: Progress | None = None,
                      cancel: Cancel | None = None) -> BoardViews:
    """The target found in each (left, right) image pair (labels default to the left image's name). A pair
    where the target is not found in both images is set aside with its reason; no usable pair at all is a
    :class:`UsvipsError` naming why for each."""
    target = as_target(target)
    if not pairs:
        raise InvalidParameterError("images", "no image pairs given")

    def step(done: int, total: int) -> None:
        if progress is not None:
            progress(done / total, f"image {done} of {total}")

    found = detect_views(target, pairs, labels, progress=step, cancelled=lambda: _is_cancelled(cancel))
    if not found.views:
        reasons = "; ".join(reason for _, reason in found.set_aside[:3])
        raise UsvipsError(f"the target is found in both images of none of the {found.total} pairs: {reasons}"
                          + (" …" if len(found.set_aside) > 3 else ""))
    return BoardViews(found.views, found.set_aside, _coverage(found.views, target), (found.summary(),))


def views_from_video(project: ProjectStore, label: str, target: CalibrationTarget | str | Path, every: int = 5,
                     max_views: int = DEFAULT_MAX_VIEWS, progress: Progress | None = None,
                     cancel: Cancel | None = None) -> BoardViews:
    """The views chosen from the project's stereo video ``label`` (every ``every``-th instant, at most
    ``max_views``; blurred and near-duplicate instants rejected). A video with no usable instant is a
    :class:`~usvips.app.video_project.VideoError` saying why."""
    target = as_target(target)
    scanned = scan_video(project, label, target, every, max_views, progress=progress, cancel=cancel)
    return BoardViews(scanned.views, scanned.set_aside, scanned.coverage, (scanned.summary()[0],))


def views_from_streams(left: VideoStream, right: VideoStream, offset: int, label: str,
                       target: CalibrationTarget | str | Path, every: int = 5, max_views: int = DEFAULT_MAX_VIEWS,
                       progress: Progress | None = None, cancel: Cancel | None = None) -> BoardViews:
    """:func:`views_from_video` on two streams already opened (``open_streams``; a worker thread cannot use
    the project's database, so the window opens them first); right frame = left frame + ``offset``. The
    streams are closed when done."""
    target = as_target(target)
    with left, right:
        scanned = scan_streams(left, right, offset, target, label, every, max_views, progress=progress,
                               cancel=cancel)
    return BoardViews(scanned.views, scanned.set_aside, scanned.coverage, (scanned.summary()[0],))


@dataclass
class BoardCalibration:
    """A calibration from board views: the adjustment's ``result`` (of the fitted views when validated),
    the ``validation`` (or None), the ``observations`` used and the views ``kept`` and ``dropped``."""

    result: CalibrationResult
    validation: Validation | None
    observations: StereoObservations
    kept: tuple[str, ...]
    dropped: tuple[str, ...]

    @property
    def calibration(self) -> StereoCalibration:
        return self.result.calibration

    def view_rms(self) -> dict[str, float]:
        """Each fitted view's reprojection RMS (pixels, per coordinate, over its kept observations): the
        view to look at first when the fit is poor."""
        squares: dict[str, list[float]] = {}
        for row in self.result.report.used_residuals():
            squares.setdefault(row.station, []).extend([row.vx ** 2, row.vy ** 2])
        return {label: float(np.sqrt(np.mean(values))) for label, values in squares.items()}

    def lines(self) -> list[str]:
        """The fit and the validation as a person reads them (one figure a line)."""
        r = self.result.report
        rms_all = r.rms_px_all
        housing = f" through {r.housing}" if r.housing != "air" else ""
        out = [f"{r.phase} calibration{housing} from {len(self.kept)} views"
               + (f" ({len(self.dropped)} dropped by you)" if self.dropped else "")
               + f": sigma0 {r.sigma0_px:.3f} px, RMS {r.rms_px:.3f} px over the kept observations"
               + (f", {rms_all:.3f} px over all" if rms_all is not None else "")
               + f", redundancy {r.redundancy}"]
        if r.suspects:
            out.append(f"  {len(r.suspects)} observations set aside as blunders")
        estimation = r.estimation
        if estimation.get("estimator") == "huber":
            gross = estimation["gross_errors"]
            out.append(f"  robust estimation: {100 * estimation['down_weighted']:.1f} % of the corners' coordinates "
                       "down-weighted (kept), " + (f"{gross} set aside as gross errors" if gross else
                                                    "none set aside as a gross error"))
        by_view = sorted(self.view_rms().items(), key=lambda item: -item[1])
        if by_view:
            out.append("  RMS per view, worst first: " + ", ".join(f"{label} {rms:.3f} px" for label, rms in by_view))
        if self.validation is not None:
            out += self.validation.lines()
        return out


def calibrate_views(target: CalibrationTarget | str | Path, views: Sequence[StereoView], phase: str = "air",
                    drop: Sequence[str] = (), base: StereoCalibration | None = None, housing: str | None = None,
                    holdout: float | None = None, seed: int = 0, options: CalibrationOptions | None = None,
                    source: dict | None = None) -> BoardCalibration:
    """Calibrate from ``views`` less those labelled in ``drop``: ``phase`` ``"air"`` (phase 1) or
    ``"water"`` (phase 2 through ``housing`` from the phase-1 ``base``). ``holdout``: a share of the views
    (0–1) held out for validation; the result is then that of the rest. A result that did not converge is a
    :class:`ConvergenceError`; too few views, a base that is not in air, an unknown housing: one line naming
    the parameter; a physically impossible phase-2 result (a port distance on its bound, residuals far above
    phase 1's): a :class:`DegenerateGeometryError` naming it.

    Phase 2 as done in a tank or a pool: ``options.cameras_unmoved`` holds each view's poses at phase 1's
    (the cameras did not move between the air and the water images; then one view will do), and
    ``options.housing_geometry`` ({"distance"|"thickness"|"n_glass"|"n_water": (value, sigma or None)})
    sets the housing values the user knows (:class:`~usvips.core.calibration.CalibrationOptions`)."""
    target = as_target(target)
    if phase not in PHASES:
        raise InvalidParameterError("phase", f"must be 'air' or 'water', got {phase!r}")
    labels = [v.label for v in views]
    unknown = sorted(set(drop) - set(labels))
    if unknown:
        raise InvalidParameterError("drop", f"no view is labelled {unknown[0]!r}")
    kept = [v for v in views if v.label not in set(drop)]
    minimum = 1 if phase == "water" else MINIMUM_VIEWS  # phase 2 knows the interior: one view will do
    if len(kept) < minimum:
        raise InvalidParameterError("views", f"{len(kept)} views kept; a calibration from a target needs at least "
                                    f"{minimum} (better 10 or more, tilted and spread over the images)")
    if holdout is not None and not 0.0 < holdout < 1.0:
        raise InvalidParameterError("holdout", f"the share of views held out must be between 0 and 1, got {holdout}")
    options = dataclasses.replace(options) if options is not None else CalibrationOptions()
    options.control_exact = bool(getattr(target, "exact", False))
    if options.image_size == (None, None):
        options.image_size = tuple(int(v) for v in kept[0].left.image_size)
    swapped = swapped_views(kept)
    if swapped:
        raise DegenerateGeometryError(
            f"view{'s' if len(swapped) > 1 else ''} {', '.join(swapped)}: the left and right images look swapped "
            f"(the target lies on the other side in the left image than in the right, unlike the other "
            f"{len(kept) - len(swapped)} views); swap {'their' if len(swapped) > 1 else 'its'} images or drop "
            f"{'them' if len(swapped) > 1 else 'it'}")
    control = target.control_points()
    observations = stereo_observations(kept)
    source = dict(source or {})
    if phase == "air":
        def fit(obs: StereoObservations) -> CalibrationResult:
            return calibrate_air(control, obs, options, source)
    else:
        if base is None:
            raise InvalidParameterError("base", "phase 2 starts from the in-air (phase-1) calibration of the same "
                                        "cameras; choose one")
        if base.phase != "air":
            raise InvalidParameterError("base", f"is a {base.phase} (phase-2) calibration; phase 2 starts from the "
                                        "in-air (phase-1) calibration of the same cameras")
        if housing is None:
            raise InvalidParameterError("housing", "phase 2 needs the housing kind")

        def fit(obs: StereoObservations) -> CalibrationResult:
            return calibrate_water(base, housing, control, obs, options, source)
    if holdout is None:
        result, validation = fit(observations), None
    else:
        validation = validate(control, observations, holdout, fit, seed,
                              compare_opencv=phase == "air" and observes_a_plane(control, observations),
                              image_size=options.image_size)
        result = validation.result
        # the calibration carries its validation: its file, the project and its report show it
        result.calibration.statistics["validation"] = validation.as_dict()
    if not result.adjustment.converged:
        raise ConvergenceError(f"the calibration did not converge ({result.adjustment.reason}); nothing kept")
    if phase == "water":
        require_physical(result, base, "nothing kept")
    return BoardCalibration(result, validation, observations, tuple(v.label for v in kept),
                            tuple(label for label in labels if label in set(drop)))


#: a view's disparity counts for the swapped-images check when it is at least this share of the image width
SWAP_DISPARITY_SHARE = 0.02


def swapped_views(views: Sequence[StereoView]) -> list[str]:
    """The labels of the views whose left and right images look swapped: the median disparity (left x −
    right x, pixels, over the points both see) of a view has the sign opposite to that of most views, and
    both it and the views' median are over :data:`SWAP_DISPARITY_SHARE` of the image width (a rig's
    disparity keeps its sign over a calibration's ranges; one near zero tells nothing). Fewer than half
    the views can be swapped: the majority defines the rig."""
    disparities = []
    for view in views:
        common = view.common_ids()
        if not common:
            disparities.append(0.0)
            continue
        left, right = view.left.subset(common).pixels, view.right.subset(common).pixels
        disparities.append(float(np.median(left[:, 0] - right[:, 0])))
    if len(disparities) < 3:
        return []
    disparity = np.array(disparities)
    width = float(views[0].left.image_size[0])
    typical = float(np.median(disparity))
    if abs(typical) < SWAP_DISPARITY_SHARE * width:
        return []
    odd = (np.sign(disparity) == -np.sign(typical)) & (np.abs(disparity) >= SWAP_DISPARITY_SHARE * width)
    if not odd.any() or odd.sum() * 2 >= len(views):
        return []
    return [view.label for view, flag in zip(views, odd, strict=True) if flag]


def store(project: ProjectStore, calibration: BoardCalibration, name: str, active_for: Sequence[str] = ()) -> int:
    """Store a converged board calibration in the project (active for the pairs named); returns its id."""
    if not calibration.result.adjustment.converged:
        raise UsvipsError("there is no converged calibration to store")
    return store_calibration(project, name.strip() or "calibration from a target", calibration.calibration,
                             active_for)
