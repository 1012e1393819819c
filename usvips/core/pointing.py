"""Pointing precision: how well a measured pixel marks the point it stands for, a quantity of its own.

Every pixel a figure is measured from has a *source* — a hand click (by an annotator, on a kind of point:
snout, fork, target centre, or generic), an accepted auto-match, a tracked point, a detector's corner, a
model's keypoint — and a pointing sigma: the standard deviation (pixels) of ONE image coordinate of that
pixel about the true image of the point (x and y alike, independent). A figure's sigma takes its pointing
share from these sigmas, never from a calibration's σ0: a board calibration's σ0 is that of detected
corners (≈ 0.06 px on rendered boards), which says nothing of how well a person clicks a snout.

The kinds of source live in :data:`SOURCES` (one :class:`SourceKind` each, with its documented default and
where the default comes from); a source with its annotator and kind of point is a :class:`Source`, stored
with each vertex as its :attr:`Source.label` text. A pointing sigma in use is a :class:`PointingSigma`: the
value, its own standard uncertainty when known, its origin (:data:`ORIGINS`), date and the number of
readings it was estimated from.

The defaults, and why (each is a prior until a project estimates its own):

- hand click: :data:`HAND_CLICK_SIGMA_PX` = 0.5 px — a prior, not a measurement of anyone's hand
  (docs/pointing.md: what was measured — the image's own definition of each kind of point, under 0.2 px
  from noise, 1–3 px of blur offset at a fork — what the verified sources say, and why 0.5 px); a
  project replaces it by estimates from its own team's data (repeated picks, double readings, tracks, the
  window's pointing test: ``usvips.app.pointing_settings``).
- auto-match accepted: :data:`AUTO_MATCH_SIGMA_PX` = 0.5 px. Normalised cross-correlation with a 2-D
  sub-pixel refinement locates a textured template to ~0.1–0.2 px, but the template is centred on the
  other image's CLICK, whose error it carries along the curve; the match is therefore no better than the
  click it follows. A weak (ambiguous or low-score) match is not given a larger sigma: a wrong peak is a
  blunder, not noise, and is a flagged fact (:class:`WeakMatch`) for the quality rules.
- tracked point: :data:`TRACKED_SIGMA_PX` = 1.0 px, for a tracked point whose start is not known. A
  tracked instant made by USVIPS stores the pointing sigma of the pick it was tracked from (its error is
  carried along; the tracker's own noise shows in the instants' spread, which combining them measures,
  ``usvips.core.measurements.instants``); a point from another tracker adds its drift (~0.5 px per few
  hundred frames on rendered fish, up to a pixel at an outline) to the pick's: 0.5² + 0.8² ≈ 1².
- detector corner: :data:`CORNER_SIGMA_PX` = 0.1 px. OpenCV's sub-pixel chessboard / ChArUco corners on
  sharp boards: rendered boards give σ0 ≈ 0.06 px, real boards 0.1–0.3 px; 0.1 px is the sharp-board
  value (a board's calibration reports its own σ0, which then is the better value).
- model keypoint: :data:`KEYPOINT_SIGMA_PX` = 2.0 px: an assumed, deliberately conservative prior (the
  fork's blur offset alone reaches 1–3 px, docs/pointing.md) until a model's own error is measured on
  validation data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.errors import InvalidParameterError

#: The default pointing sigma (px, one coordinate) of a person's click (see the module's text). The ONE
#: place this number lives: a measured value replaces it here.
HAND_CLICK_SIGMA_PX = 0.5
AUTO_MATCH_SIGMA_PX = 0.5
TRACKED_SIGMA_PX = 1.0
CORNER_SIGMA_PX = 0.1
KEYPOINT_SIGMA_PX = 2.0

#: where a pointing sigma comes from: the source's documented default, given by the user (a command's
#: option, a project setting), or estimated from data (repeated picks, a pointing test)
ORIGINS = ("default", "given", "estimated")

#: the kinds of point a person clicks (a hand click's qualifier); "generic" when not said
POINT_KINDS = ("generic", "snout", "fork", "target centre")


@dataclass(frozen=True)
class SourceKind:
    """A kind of pointing source: its name (stored), its default sigma (px, one coordinate) and where that
    default comes from (one sentence, shown where the default is used)."""

    name: str
    default_px: float
    basis: str


SOURCES: dict[str, SourceKind] = {s.name: s for s in (
    SourceKind("hand click", HAND_CLICK_SIGMA_PX,
               "assumed: a prior above the image's own noise floor; docs/pointing.md says what it rests on"),
    SourceKind("auto-match", AUTO_MATCH_SIGMA_PX,
               "assumed: a correlation match follows the click it was made from, so no better than a click"),
    SourceKind("tracked", TRACKED_SIGMA_PX, "assumed: the start pick (0.5 px) and the tracker's drift (0.8 px)"),
    SourceKind("corner", CORNER_SIGMA_PX, "assumed: sub-pixel corners on a sharp board"),
    SourceKind("keypoint", KEYPOINT_SIGMA_PX, "assumed: a conservative prior until a model's error is measured"),
)}

#: the qualifier of a source label whose RIGHT pixel was found by matching its LEFT pixel along the epipolar
#: curve (a model's keypoint refined in the right image): its right error is the left error carried over plus
#: the match's own, so the two are correlated (:func:`vertex_correlation`)
RIGHT_FOLLOWS_LEFT = "right matched to left"

#: the qualifier of a model keypoint's source label that gives the correlation of the model's pointing errors
#: on one fish between frames, as measured for the model (e.g. "frame correlation 0.42";
#: :func:`frame_correlation_of`, :mod:`usvips.core.measurements.instants`)
FRAME_CORRELATION = "frame correlation"

#: the source of a vertex stored before pointing sources were (schema < 11): a hand click of unknown
#: annotator and kind of point, with the hand-click default
MIGRATED_SOURCE = "hand click (unknown)"


@dataclass(frozen=True)
class Source:
    """Where one measured pixel comes from: a kind of source (a key of :data:`SOURCES`), and for a hand
    click the kind of point (one of :data:`POINT_KINDS`, "" when not said) and the annotator ("" when not
    known). :attr:`label` is the stored text; :func:`source_from_label` reads it back."""

    kind: str = "hand click"
    point: str = ""
    annotator: str = ""

    def __post_init__(self) -> None:
        if self.kind not in SOURCES:
            raise InvalidParameterError("source", f"unknown pointing source {self.kind!r}; known: "
                                                  f"{', '.join(SOURCES)}")
        if self.point and self.point not in POINT_KINDS:
            raise InvalidParameterError("point", f"unknown kind of point {self.point!r}; known: "
                                                 f"{', '.join(POINT_KINDS)}")

    @property
    def label(self) -> str:
        """``kind``, or ``kind (point, by annotator)`` with what is known (e.g. "hand click (snout, by ana)")."""
        parts = [p for p in (self.point, f"by {self.annotator}" if self.annotator else "") if p]
        return f"{self.kind} ({', '.join(parts)})" if parts else self.kind

    @property
    def default(self) -> PointingSigma:
        """The documented default sigma of this source's kind."""
        return PointingSigma(SOURCES[self.kind].default_px)


def source_from_label(label: str) -> Source:
    """The :class:`Source` a stored label names; :data:`MIGRATED_SOURCE` (and any qualifier that is not a
    kind of point or an annotator) reads as a hand click of unknown point and annotator."""
    text = (label or "").strip()
    kind, _, rest = text.partition(" (")
    if kind not in SOURCES:
        raise InvalidParameterError("source", f"unknown pointing source {text!r}; known: {', '.join(SOURCES)}")
    point, annotator = "", ""
    for part in (p.strip() for p in rest.rstrip(")").split(",") if rest):
        if part in POINT_KINDS:
            point = part
        elif part.startswith("by "):
            annotator = part[3:]
    return Source(kind, point, annotator)


@dataclass(frozen=True)
class PointingSigma:
    """A pointing sigma in use: ``value_px`` (px, one image coordinate, > 0), its own standard uncertainty
    ``uncertainty_px`` when known (an estimate from n readings; None for a default or a given value), its
    ``origin`` (one of :data:`ORIGINS`), the ``date`` it was estimated or given (ISO 8601 text, "" when
    not) and the number ``n`` of readings it rests on (None when not estimated)."""

    value_px: float
    uncertainty_px: float | None = None
    origin: str = "default"
    date: str = ""
    n: int | None = None

    def __post_init__(self) -> None:
        if not np.isfinite(self.value_px) or self.value_px <= 0:
            raise InvalidParameterError("pointing_sigma_px", f"must be finite and > 0, got {self.value_px}")
        if self.origin not in ORIGINS:
            raise InvalidParameterError("origin", f"must be one of {', '.join(ORIGINS)}, got {self.origin!r}")
        if self.uncertainty_px is not None and not (np.isfinite(self.uncertainty_px) and self.uncertainty_px >= 0):
            raise InvalidParameterError("uncertainty_px", f"must be finite and >= 0, got {self.uncertainty_px}")

    @property
    def text(self) -> str:
        """How a person reads it: "0.50 px (default)", "0.42 ± 0.05 px (estimated, n 120, 2026-11-28)"."""
        value = f"{self.value_px:.2f}" + (f" ± {self.uncertainty_px:.2f}" if self.uncertainty_px is not None else "")
        details = [self.origin] + ([f"n {self.n}"] if self.n is not None else []) + ([self.date] if self.date else [])
        return f"{value} px ({', '.join(details)})"


#: the default of a hand click, the one used wherever a pixel's source is not said
DEFAULT = PointingSigma(HAND_CLICK_SIGMA_PX)


def default_sigma(source: str | Source | None = None) -> float:
    """The default pointing sigma (px) of ``source`` (a :class:`Source`, a stored label, or None: a hand
    click, the documented default for an unspecified source)."""
    if source is None:
        return HAND_CLICK_SIGMA_PX
    if isinstance(source, str):
        source = source_from_label(source)
    return SOURCES[source.kind].default_px


def per_vertex(pointing_sigma_px: float | np.ndarray | None, count: int) -> np.ndarray:
    """The pointing sigmas (count, 2) px — [left, right] per vertex — of a scalar, an (N,) array (per
    vertex, both sides alike) or an (N, 2) array; None: the hand-click default (one value for all gives a
    read-only view whose rows share one row of memory). A wrong shape or a value
    that is not finite and > 0 is an :class:`InvalidParameterError` on ``pointing_sigma_px``."""
    sigma = np.asarray(HAND_CLICK_SIGMA_PX if pointing_sigma_px is None else pointing_sigma_px, dtype=np.float64)
    if sigma.ndim == 0:
        out = np.broadcast_to(np.full((1, 2), float(sigma)), (count, 2))  # one row for all: no (N, 2) copy
    elif sigma.shape == (count,):
        out = np.repeat(sigma[:, None], 2, axis=1)
    elif sigma.shape == (count, 2):
        out = sigma.copy()
    else:
        raise InvalidParameterError("pointing_sigma_px", f"expected a scalar, ({count},) or ({count}, 2) for "
                                                         f"{count} vertices, got shape {sigma.shape}")
    if not np.all(np.isfinite(out)) or np.any(out <= 0):
        raise InvalidParameterError("pointing_sigma_px", "every pointing sigma must be finite and > 0 (pixels)")
    if out.strides[0] != 0 and out.size and np.all(out == out[0, 0]):  # one value for all: one row of memory,
        out = np.broadcast_to(out[:1, :1], (count, 2))                 # which the intersection weights once
    return out


@dataclass(frozen=True)
class WeakMatch:
    """An auto-match accepted although the matcher refused it (ambiguous, textureless, a low score): its
    correlation ``score`` (NCC, −1..1; None when the proposal came without one, e.g. from a track) and the
    ``reason``. A stored fact of the vertex, for the quality rules — never a note a later edit can erase."""

    score: float | None
    reason: str

    @property
    def text(self) -> str:
        score = f"correlation {self.score:.2f}: " if self.score is not None else ""
        return f"weak auto-match accepted ({score}{self.reason})"


def vertex_pointing(sources: list[str], sigmas: list[tuple[float, float] | None], origins: list[str]
                    ) -> tuple[np.ndarray, str, tuple[str, ...]]:
    """The pointing of an object's stored vertices: their sigmas (N, 2) px [left, right] — a vertex's stated
    sigmas, else its source's default —, one word for their origin (``default``, ``given``, ``estimated``,
    or several joined by "+") and the marks a figure from them carries (a default used for vertices of
    unknown source). ``sources``: the vertices' source labels; ``sigmas``: their stated (left, right) or
    None; ``origins``: the stated sigmas' origins."""
    out = np.array([s if s is not None else (default_sigma(src),) * 2 for src, s in zip(sources, sigmas, strict=True)],
                   dtype=np.float64).reshape(-1, 2)
    used = [o if s is not None else "default" for s, o in zip(sigmas, origins, strict=True)]
    origin = "+".join(o for o in ORIGINS if o in used) or "default"
    unknown = sum(1 for src, s in zip(sources, sigmas, strict=True) if s is None and src == MIGRATED_SOURCE)
    marks = (f"pointing sigma {HAND_CLICK_SIGMA_PX:.2f} px is the hand-click default for {unknown} vertex(es) of "
             "unknown source",) if unknown else ()
    return out, origin, marks


def right_follows_left(label: str) -> bool:
    """Whether a stored source label says its right pixel was matched to its left one
    (:data:`RIGHT_FOLLOWS_LEFT` among its qualifiers)."""
    _, _, rest = (label or "").partition(" (")
    return RIGHT_FOLLOWS_LEFT in (p.strip() for p in rest.rstrip(")").split(","))


def frame_correlation_qualifier(value: float) -> str:
    """The source label's qualifier stating the frame correlation ``value`` (0..1) of a model's keypoints."""
    if not 0.0 <= value < 1.0:
        raise InvalidParameterError("frame_correlation", f"must lie in [0, 1), got {value:g}")
    return f"{FRAME_CORRELATION} {value:.3f}"


def frame_correlation_of(label: str) -> float | None:
    """The frame correlation a stored source label states (:data:`FRAME_CORRELATION`), None when it states
    none or a value that is not a number in [0, 1)."""
    _, _, rest = (label or "").partition(" (")
    for part in (p.strip() for p in rest.rstrip(")").split(",")):
        if part.startswith(FRAME_CORRELATION + " "):
            try:
                value = float(part[len(FRAME_CORRELATION) + 1:])
            except ValueError:
                return None
            return value if 0.0 <= value < 1.0 else None
    return None


def vertex_correlation(sources: list[str], sigmas: np.ndarray) -> np.ndarray | None:
    """The correlation of each vertex's left and right pointing errors (N,), or None when every vertex's are
    independent: for a vertex whose right pixel follows its left one (:func:`right_follows_left`), the right
    error is the left error (σ_L) plus the match's own, independent error, so σ_R ≥ σ_L and the correlation
    is σ_L / σ_R (:mod:`usvips.core.measurements.correlated_pointing`); a stated σ_R below σ_L cannot be such
    a sum, and is taken as independent. ``sigmas``: (N, 2) [left, right] px as :func:`vertex_pointing` gives."""
    sigmas = np.asarray(sigmas, dtype=np.float64).reshape(-1, 2)
    follows = np.array([right_follows_left(s) for s in sources], dtype=bool)
    rho = np.where(follows & (sigmas[:, 1] > sigmas[:, 0]), sigmas[:, 0] / sigmas[:, 1], 0.0)
    return rho if np.any(rho > 0) else None
