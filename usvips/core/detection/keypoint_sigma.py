"""A model's keypoint pointing sigma, MEASURED per keypoint: never assumed.

The pointing sigma of a keypoint (px, one image coordinate: x and y alike, independent) is the standard
deviation of the model's point about the true image of the point it stands for. It is measured from pairs
(the model's point, a reference point):

- on validation data with truth (:func:`sigma_from_truth`): the reference is the true image of the point;
- from the reviewers' corrections of accepted proposals (:func:`sigma_from_corrections`): the reference is
  where the reviewer left the point. A keypoint the reviewer accepted without moving counts as a
  difference of zero (the reviewer judged it right); the reviewer's own pointing sigma (a hand click's,
  :data:`usvips.core.pointing.HAND_CLICK_SIGMA_PX` unless said) is taken out in quadrature, since the
  difference carries both.

The scale is robust: 1.4826 × the median absolute coordinate difference (the normal distribution's
sigma when most differences are normal; a few blunders — a keypoint on the wrong fin — do not inflate it,
and a blunder is a refusal for the reviewer, not noise). The differences are taken about ZERO, not about
their median: a model that points consistently off (a bias) has that bias in its pointing error. Its own
standard uncertainty is 1.1664 × sigma / √m for m coordinate differences (the median absolute deviation's
asymptotic efficiency under normality, 0.3675).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from usvips.core.errors import InvalidParameterError
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, PointingSigma

#: the normal distribution's sigma over its median absolute deviation
MAD_TO_SIGMA = 1.482602218505602
#: the standard deviation of the MAD-based sigma, in sigmas × √m (normal data; efficiency 0.3675)
MAD_SIGMA_SPREAD = 1.1664
#: the fewest points (model point and reference pairs) a keypoint's sigma is measured from
MIN_POINTS = 10


@dataclass(frozen=True)
class KeypointSigma:
    """A keypoint's measured pointing sigma: its ``name``, the :class:`PointingSigma` (value, uncertainty,
    origin "estimated", date, ``n`` points) and ``basis``: what it was measured from (one phrase)."""

    name: str
    sigma: PointingSigma
    basis: str

    @property
    def text(self) -> str:
        return f"{self.name}: {self.sigma.text}, {self.basis}"


def robust_scale(differences: np.ndarray) -> tuple[float, float]:
    """(sigma, its standard uncertainty) in px of coordinate differences (m,) about zero (see the module
    docstring)."""
    values = np.abs(np.asarray(differences, dtype=np.float64).ravel())
    sigma = MAD_TO_SIGMA * float(np.median(values))
    return sigma, MAD_SIGMA_SPREAD * sigma / np.sqrt(len(values))


def _measure(names: Sequence[str], model: np.ndarray, reference: np.ndarray, basis: str, reference_sigma_px: float,
             date: str) -> dict[str, KeypointSigma]:
    names = tuple(names)
    model, reference = np.asarray(model, dtype=np.float64), np.asarray(reference, dtype=np.float64)
    if model.shape != reference.shape or model.ndim != 3 or model.shape[1:] != (len(names), 2):
        raise InvalidParameterError("keypoints", f"expected model and reference points of one shape (n, "
                                                 f"{len(names)}, 2) for keypoints {names}, got {model.shape} and "
                                                 f"{reference.shape}")
    if not 0 <= reference_sigma_px < np.inf:
        raise InvalidParameterError("reference_sigma_px", f"must be finite and >= 0, got {reference_sigma_px}")
    out: dict[str, KeypointSigma] = {}
    for k, name in enumerate(names):
        usable = np.isfinite(model[:, k]).all(axis=1) & np.isfinite(reference[:, k]).all(axis=1)
        if usable.sum() < MIN_POINTS:
            raise InvalidParameterError("keypoints", f"keypoint {name!r}: {int(usable.sum())} points with a "
                                                     f"reference, at least {MIN_POINTS} are needed to measure "
                                                     "its pointing sigma")
        scale, spread = robust_scale(model[usable, k] - reference[usable, k])
        sigma = float(np.sqrt(max(scale ** 2 - reference_sigma_px ** 2, 0.0)))
        if sigma <= 0:
            raise InvalidParameterError("keypoints", f"keypoint {name!r}: its differences ({scale:.2f} px) are "
                                                     f"no larger than the reference's own sigma "
                                                     f"({reference_sigma_px:.2f} px): the model's sigma cannot "
                                                     "be told from the reference's")
        uncertainty = spread * scale / sigma  # d sigma = scale / sigma · d scale
        out[name] = KeypointSigma(name, PointingSigma(sigma, uncertainty, "estimated", date, int(usable.sum())),
                                  basis)
    return out


def sigma_from_truth(names: Sequence[str], model: np.ndarray, truth: np.ndarray,
                     date: str = "") -> dict[str, KeypointSigma]:
    """Each keypoint's pointing sigma (px) from validation data: the model's points (n, K, 2) px against the
    true images (n, K, 2) px of the points, keypoints in ``names`` order; NaN where a keypoint was not
    found (a miss, left out). At least :data:`MIN_POINTS` per keypoint."""
    return _measure(names, model, truth, "validation data with truth", 0.0, date)


def sigma_from_corrections(names: Sequence[str], proposed: np.ndarray, reviewed: np.ndarray,
                           reviewer_sigma_px: float = HAND_CLICK_SIGMA_PX,
                           date: str = "") -> dict[str, KeypointSigma]:
    """Each keypoint's pointing sigma (px) from accepted proposals: the model's points (n, K, 2) px against
    where the reviewers left them (n, K, 2) px — moved, or not (a difference of zero) — with the reviewers'
    own pointing sigma ``reviewer_sigma_px`` taken out in quadrature. At least :data:`MIN_POINTS` per
    keypoint."""
    return _measure(names, proposed, reviewed, f"reviewers' corrections (reviewer sigma "
                                               f"{reviewer_sigma_px:.2f} px taken out)", reviewer_sigma_px, date)


@dataclass(frozen=True)
class SizeSigma:
    """A pointing sigma that grows with the fish's size: σ(s) = √(a² + (b·s)²) px, ``s`` the fish's
    snout–fork length (px, in the same pixels as σ), ``a`` px and ``b`` (px per px) MEASURED by
    :func:`fit_size_sigma`, with ``n`` the coordinate errors they rest on."""

    a: float
    b: float
    n: int = 0

    def __call__(self, size_px: float | np.ndarray) -> float | np.ndarray:
        return np.sqrt(self.a ** 2 + (self.b * np.asarray(size_px, dtype=np.float64)) ** 2)


def fit_size_sigma(size_px: np.ndarray, errors_px: np.ndarray) -> SizeSigma:
    """:class:`SizeSigma` of coordinate errors ``errors_px`` (m, 2) px — x and y of each point, independent,
    normal with σ(s) — at sizes ``size_px`` (m,) px, by maximum likelihood. Unlike the robust scale of
    :func:`robust_scale`, this is the errors' second moment: the few gross misses a model makes (and that grow
    with the fish) are counted, as a length's NEES counts them. At least :data:`MIN_POINTS` points."""
    from scipy.optimize import minimize

    size = np.asarray(size_px, dtype=np.float64).reshape(-1)
    errors = np.asarray(errors_px, dtype=np.float64).reshape(len(size), -1)
    usable = np.isfinite(size) & np.all(np.isfinite(errors), axis=1) & (size > 0)
    size, errors = size[usable], errors[usable]
    if len(size) < MIN_POINTS:
        raise InvalidParameterError("errors_px", f"{len(size)} points with a size and an error: at least "
                                                 f"{MIN_POINTS} are needed to fit a sigma by size")
    square = np.sum(errors ** 2, axis=1)  # per point, over its coordinates
    coordinates = errors.shape[1]
    scale = float(np.sqrt(np.mean(square) / coordinates)) or 1e-6

    def cost(theta: np.ndarray) -> float:
        variance = np.exp(2 * theta[0]) + np.exp(2 * theta[1]) * size ** 2
        return float(np.sum(coordinates * np.log(variance) + square / variance))

    start = np.log([scale, max(scale / np.median(size), 1e-9)])
    found = min((minimize(cost, start + shift, method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-9,
                                                                                 "maxiter": 4000})
                 for shift in (np.zeros(2), np.array([0.0, -4.0]), np.array([-4.0, 0.0]))), key=lambda r: r.fun)
    a, b = np.exp(found.x)
    return SizeSigma(float(a), float(b), int(len(size) * coordinates))


@dataclass(frozen=True)
class StereoSigma:
    """How a model's refined stereo keypoints err, per keypoint, MEASURED on rendered clips with truth
    (:mod:`usvips.training.stereo_sigma`): the LEFT keypoint's pointing σ by the fish's size (``left``:
    model input px, size in input px — the model's error scales with its input) and the refined RIGHT
    keypoint's error about the left one's conjugate (``match``: image px, size in image px — the match is made
    on the image). The right error of a refined keypoint is the left one carried over plus the match's:
    σ_R² = σ_L² + σ_m², correlated with the left by σ_L / σ_R
    (:mod:`usvips.core.measurements.correlated_pointing`). A right keypoint the match could not refine is
    the model's own, independent of the left: ``unmatched`` (model input px, size in input px) is its σ,
    measured on the pairs that got a length so (their gross misses are not caught in stereo); the left σ
    where it gives none. ``basis``: what they were measured on."""

    left: dict[str, SizeSigma]
    match: dict[str, SizeSigma]
    basis: str = ""
    unmatched: dict[str, SizeSigma] = field(default_factory=dict)

    def pointing(self, names: Sequence[str], size_image_px: float, input_per_image_px: float,
                 refined: Sequence[bool]) -> tuple[np.ndarray, np.ndarray]:
        """(sigmas (K, 2) image px [left, right], correlations (K,)) of a pair's keypoints ``names`` for a fish
        ``size_image_px`` long in the left image, ``input_per_image_px`` the letterbox's scale, and whether
        each right keypoint was ``refined`` (else it is the model's own point: independent, of the
        ``unmatched`` σ)."""
        missing = [n for n in names if n not in self.left or n not in self.match]
        if missing:
            raise InvalidParameterError("stereo_sigma", f"no measured stereo sigma for {', '.join(missing)}")
        scale = float(input_per_image_px)
        left = np.array([float(self.left[n](size_image_px * scale)) / scale for n in names])
        match = np.array([float(self.match[n](size_image_px)) for n in names])
        own = np.array([float(self.unmatched.get(n, self.left[n])(size_image_px * scale)) / scale for n in names])
        follows = np.asarray(refined, dtype=bool)
        right = np.where(follows, np.sqrt(left ** 2 + match ** 2), own)
        return np.stack([left, right], axis=1), np.where(follows, left / right, 0.0)
