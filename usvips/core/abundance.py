"""Relative abundance of a stereo-video sample: MaxN, the largest number of individuals of one taxon seen
together in one frame (the usual count of BRUV and DOV surveys, GlobalArchive's and CheckEM's ``Count``),
from the counted observations. Pure computation."""

from __future__ import annotations

from collections.abc import Hashable, Sequence

from usvips.core.errors import InvalidParameterError


def max_n(groups: Sequence[Hashable], frames: Sequence[Hashable], numbers: Sequence[int]) -> dict[Hashable, int]:
    """Group (e.g. (sample, taxon)) → MaxN: for each group, the individuals of its observations summed per
    frame, the largest of those sums. ``frames`` names the frame (the instant) of each observation,
    ``numbers`` its individuals (whole numbers ≥ 1). Groups in order of first appearance."""
    if not len(groups) == len(frames) == len(numbers):
        raise InvalidParameterError("observations", f"{len(groups)} groups, {len(frames)} frames, {len(numbers)} "
                                    "numbers: one of each per observation")
    per_frame: dict[Hashable, dict[Hashable, int]] = {}
    for group, frame, number in zip(groups, frames, numbers, strict=True):
        if isinstance(number, bool) or int(number) != number or number < 1:
            raise InvalidParameterError("number", f"must be a whole number of individuals ≥ 1, got {number!r}")
        frames_of = per_frame.setdefault(group, {})
        frames_of[frame] = frames_of.get(frame, 0) + int(number)
    return {group: max(counts.values()) for group, counts in per_frame.items()}
