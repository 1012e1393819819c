"""Stereo views of a calibration target from image pairs: each pair's left and right images read and the
target found in both with its kind's detector (:mod:`usvips.core.calibration_targets`).

A pair that cannot be used — an image that cannot be read, a target not found, found by one camera only,
too few points in both, an image of another size than the others from that camera — is set aside with
one line naming the view, the image and why; the others become :class:`StereoView` s for the calibration
(:func:`~usvips.core.calibration_targets.stereo_observations`). Reads files only (no project), so the
window runs it in a worker: ``progress(done, total)`` after each image, ``cancelled()`` checked before
each image (then :class:`InterruptedError`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from usvips.core.calibration_targets import CalibrationTarget, StereoView
from usvips.core.errors import UsvipsError
from usvips.io.images import read_image


@dataclass(frozen=True)
class TargetViews:
    """The views in which both cameras see the target, and the pairs set aside (label, one-line reason)."""

    views: tuple[StereoView, ...]
    set_aside: tuple[tuple[str, str], ...]
    total: int

    def summary(self) -> str:
        """One line: how many pairs became views."""
        points = sum(len(view.common_ids()) for view in self.views)
        return (f"the target is found in both images of {len(self.views)} of {self.total} pairs "
                f"({points} points seen by both cameras); {len(self.set_aside)} set aside")


def _labels(pairs: Sequence[tuple[Path, Path]], labels: Sequence[str] | None) -> list[str]:
    if labels is not None:
        if len(labels) != len(pairs) or len(set(labels)) != len(labels):
            raise UsvipsError(f"{len(labels)} view labels for {len(pairs)} pairs; give one distinct label per pair")
        return [str(label) for label in labels]
    stems = [Path(left).stem for left, _ in pairs]
    return stems if len(set(stems)) == len(stems) else [f"{k + 1}:{stem}" for k, stem in enumerate(stems)]


def detect_views(target: CalibrationTarget, pairs: Sequence[tuple[str | Path, str | Path]],
                 labels: Sequence[str] | None = None, minimum_points: int = 4,
                 progress: Callable[[int, int], None] | None = None,
                 cancelled: Callable[[], bool] | None = None) -> TargetViews:
    """Find ``target`` in every (left, right) image pair. ``labels`` name the views (default: the left
    image's name); a view needs ``minimum_points`` points found in both images."""
    pairs = [(Path(left), Path(right)) for left, right in pairs]
    names = _labels(pairs, labels)
    total = 2 * len(pairs)
    done = 0
    sizes: dict[str, tuple[int, int]] = {}
    views, set_aside = [], []
    for label, (left_path, right_path) in zip(names, pairs, strict=True):
        found, problems = {}, []
        for side, path in (("left", left_path), ("right", right_path)):
            if cancelled is not None and cancelled():
                raise InterruptedError(f"target detection cancelled after {done // 2} of {len(pairs)} pairs")
            try:
                image = read_image(path)
                detection = target.detect(image)
            except (UsvipsError, OSError) as error:
                problems.append(f"{side} image: {error}")
            else:
                size = detection.image_size
                if sizes.setdefault(side, size) != size:
                    problems.append(f"{side} image {path.name} is {size[0]} × {size[1]} px, the earlier {side} "
                                    f"images {sizes[side][0]} × {sizes[side][1]}")
                elif not detection:
                    problems.append(f"{side} image {path.name}: {detection.reason}")
                else:
                    found[side] = detection
            done += 1
            if progress is not None:
                progress(done, total)
        if problems:
            if len(found) == 1:
                problems.append(f"the target is seen by the {next(iter(found))} camera only")
            set_aside.append((label, f"view {label}: " + "; ".join(problems)))
            continue
        view = StereoView(label, found["left"], found["right"], {"left": str(left_path), "right": str(right_path)})
        common = len(view.common_ids())
        if common < minimum_points:
            set_aside.append((label, f"view {label}: only {common} target points are found in both images (at "
                              f"least {minimum_points} needed)"))
            continue
        views.append(view)
    return TargetViews(tuple(views), tuple(set_aside), len(pairs))
