"""Issue 35's acceptance, honestly: the shipped model run end to end as ``usvips detect`` runs it on rendered
stereo survey clips with truth (random rigs of every housing kind, seeds the training, the shipping step, the
model's [stereo_sigma] fit and the bench never use): no proposal pairs two different fish, and the lengths' σ
holds their errors — the share within 2σ and the NEES within what an honest σ gives over this many lengths,
and in each band of the fish's size in the image (bounds from their count, not tuned). The recall target
(90 % of the fish measured) is the model's, reported by the bench row ``detection_acceptance``, not asserted
here."""

import math

import numpy as np
import pytest

from usvips.app.detection_acceptance import AcceptanceFigures, assign, measure_acceptance, nees_bounds
from usvips.app.detection_model import bundled_model_path, load_model

#: the clips' seeds: a range nothing else renders
SEEDS = range(40_000_000, 40_000_016)


def within_bound(count: int, sigmas: float = 3.0) -> float:
    """The smallest share within 2σ an honest σ gives over ``count`` lengths, ``sigmas`` binomial standard
    deviations below the normal distribution's 95.45 %."""
    p = math.erf(2 / math.sqrt(2))
    return p - sigmas * math.sqrt(p * (1 - p) / count)


@pytest.fixture(scope="module")
def figures(tmp_path_factory) -> AcceptanceFigures:
    return measure_acceptance(load_model(bundled_model_path()), SEEDS, tmp_path_factory.mktemp("clips"))


def test_no_proposal_pairs_two_different_fish(figures):
    assert figures.to_measure >= 60 and figures.proposals >= 40
    assert figures.cross_fish == 0


def test_the_lengths_sigma_holds_their_errors(figures):
    """Before pairs with a keypoint at an image's edge (a fish cut by the frame) got no length, the NEES here
    was 1.71 (one snout beyond the edge gave a length 8.5σ short). With the model shipped since (448 px input),
    its validated σ alike and independent in both images gave a NEES of 7.1 (one length 25σ short, the rest
    far too cautious); with its [stereo_sigma] (the refined right keypoint following the left, σ by the
    fish's size, gross misses counted) it is 0.73 over 94 lengths."""
    count = len(figures.single)
    assert count >= 40
    assert figures.within_2sigma >= within_bound(count)
    assert abs(figures.nees - 1) <= 3 * math.sqrt(2 / count)


def test_the_lengths_sigma_holds_by_the_fishs_size_in_the_image(figures):
    """In each band of the fish's snout–fork length in the left image, the NEES lies within what an honest σ
    gives for the band's count of fish (a model's error on one fish repeats on its frames, so its lengths are
    not independent). With its validated σ alike and independent in both images, the model shipped before had
    0.06 here for fish 20–50 px long; with [stereo_sigma] the model shipped now has 0.78 (29 lengths, 9 fish),
    0.53 (35, 10), 0.36 (25, 8) and 2.8 (3, 2) at 20–50, 50–100, 100–200 and over 200 px."""
    bands = [band for band in figures.by_size() if band["fish"] >= 3]
    assert sum(band["lengths"] for band in bands) >= 40
    for band in bands:
        low, high = band["nees_bounds"]
        assert low <= band["nees"] <= high, band


def test_a_fish_joined_over_frames_has_an_honest_combined_sigma(figures):
    """Before the instants of a model's proposals shared their pointing error, the combined lengths of fish
    joined over 4 frames had a NEES of 3.0 on the bench's clips; sharing it whole gave 0.26 here (0.37 on the
    bench's); by the shipped model's measured frame correlation ([frame_correlation]) 0.54 (0.72): within the
    bounds an honest σ gives for this many fish, which are independent of each other."""
    count = len(figures.combined)
    assert count >= 8
    low, high = nees_bounds(count)
    assert low <= AcceptanceFigures.nees_of(figures.combined) <= high


def test_a_detection_is_the_fish_its_snout_and_fork_lie_near():
    class Truth:
        def __init__(self, snout, fork):
            self.keypoints = np.array([snout, fork, snout, fork], float)
            self.length_pixels = float(np.linalg.norm(np.subtract(fork, snout)))

    fish = [Truth((100, 100), (200, 100)), Truth((300, 300), (350, 300))]
    detections = np.array([[[302, 301], [349, 299]],  # fish 1 (50 px: within 10 px)
                           [[110, 104], [205, 96]],   # fish 0 (100 px: within 20 px)
                           [[330, 300], [380, 300]]])  # 30 px off fish 1 and it is taken: no fish
    assert assign(detections, fish) == [1, 0, None]
    assert assign(detections[:0], fish) == [] and assign(detections, []) == [None] * 3


def test_lengths_of_no_fish_are_counted_apart_and_few(figures):
    """A proposal with a length of which one image's detection is no fish (its keypoints more than 0.2 of a
    length off any fish's) is no fish measured, but a person reviewing it reads a length: it is counted
    (``lengths_not_a_fish``) and, where the other image's detection is a fish, scored against that fish apart
    (``half_a_fish``). On the [stereo_sigma] fit's seeds they were 14 of 381 lengths (3.7 %), the 10 scored
    with a NEES of 80: no σ covers them — they are what review is for. Here 3 of 108 (one 17σ off its one
    image's fish), before and after pairs with an unmatched keypoint and lengths 1.5 × apart got none."""
    summary = figures.summary()
    assert summary["lengths_not_a_fish"] == figures.lengths_not_a_fish >= len(figures.half_matched)
    assert summary["lengths_half_a_fish"] == len(figures.half_matched)
    assert figures.lengths_not_a_fish <= 0.1 * (len(figures.single) + figures.lengths_not_a_fish)
