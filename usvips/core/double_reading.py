"""Double reading: pairing the objects two readers (annotators) measured on the same imagery, and how
well their figures agree. Pure computation: arrays in, arrays out.

Each reader's objects are given as a :class:`ReaderObjects` (parallel arrays). Two objects can be the
same fish when they were measured on the same video or image pair (``source``), are of the same kind,
their identifications agree (:func:`taxa_agree`), at the same instant within a tolerance —
``tolerance_s`` seconds, or ``tolerance_frames`` frames of the video (exactly one of the two; objects
on an image pair have neither time nor frame, NaN: the pair is the instant) — and their 3-D midpoints
are within ``gate_m`` metres. Among those
candidates the pairs are chosen by a minimum-total-distance assignment of midpoints (Hungarian method,
:func:`scipy.optimize.linear_sum_assignment`), each object at most once. An object whose instant is not
known (``instant_known`` False: measured on a video but stored with neither a time nor a frame) pairs
with nothing: it is left unmatched, and the caller says why.

A matched pair is flagged when its main figures (lengths) differ by more than ``k`` combined standard
deviations, ``|a − b| > k·sqrt(σa² + σb²)``; with honest, independent σ and ``k = 2`` about 4.6 % of
true pairs are flagged by chance. Note that two readers measuring one fish on one calibration share
that calibration's error, which cancels in ``a − b``: when σ includes it the test is conservative.

Identifications are (family, genus, species) triples, compared level by level (:func:`taxa_agree`): a
coarser identification agrees with a finer one when they agree on every level both give and they give at
least one level in common; an unidentified object (no level) agrees only with another unidentified one.

Conventions: metres, seconds; taxon names compared ignoring case and surrounding spaces, a species
``spp``/``sp.`` (genus only) counting as not given ('' = not given).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from usvips.core.errors import InvalidParameterError

#: 1.96: the Bland–Altman limits of agreement are the mean difference ± this many SDs (95 %)
LIMITS_Z = 1.959963984540054


@dataclass(frozen=True)
class ReaderObjects:
    """One reader's objects as parallel arrays of length N: ``ids`` (N,) int, ``source`` (N,) str (the
    video or image pair they were measured on), ``kind`` (N,) str, ``species`` (N,) str, ``time_s`` (N,)
    float seconds (NaN on an image pair), ``midpoint`` (N, 3) m (mean of the object's vertices, in the
    frame its source measures in), ``value`` (N,) and ``sigma`` (N,) of the main figure (m for a length);
    ``frame`` (N,) float, the video's (left) frame index (NaN on an image pair or when unknown; default all
    NaN), compared when the tolerance is given in frames; ``instant_known`` (N,) bool (default all True):
    False for an object whose instant is unknown (on a video, with neither time nor frame), never paired;
    ``taxon`` (N, 3) str, the identification (family, genus, species; '' where not given), compared by
    :func:`taxa_agree` — by default each ``species`` text as a species alone (two such agree when they
    are equal). ``species`` is the name shown for the object."""

    ids: np.ndarray
    source: np.ndarray
    kind: np.ndarray
    species: np.ndarray
    time_s: np.ndarray
    midpoint: np.ndarray
    value: np.ndarray
    sigma: np.ndarray
    frame: np.ndarray | None = None
    instant_known: np.ndarray | None = None
    taxon: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(np.asarray(self.ids))
        if self.frame is None:
            object.__setattr__(self, "frame", np.full(n, np.nan))
        if self.instant_known is None:
            object.__setattr__(self, "instant_known", np.ones(n, bool))
        if self.taxon is None:
            object.__setattr__(self, "taxon", [("", "", str(name)) for name in np.asarray(self.species, object)])
        conversions = {"ids": (np.int64, (n,)), "source": (str, (n,)), "kind": (str, (n,)),
                       "species": (str, (n,)), "time_s": (np.float64, (n,)), "midpoint": (np.float64, (n, 3)),
                       "value": (np.float64, (n,)), "sigma": (np.float64, (n,)), "frame": (np.float64, (n,)),
                       "instant_known": (bool, (n,)), "taxon": (str, (n, 3))}
        for name, (dtype, shape) in conversions.items():
            array = np.asarray(getattr(self, name), dtype=dtype if dtype is not str else object)
            if n == 0:
                array = array.reshape(shape)
            if array.shape != shape:
                raise InvalidParameterError(name, f"must have shape {shape}, got {array.shape}")
            object.__setattr__(self, name, array)
        object.__setattr__(self, "taxon", _normalised_taxa(self.taxon))
        for name in ("midpoint", "value"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise InvalidParameterError(name, "must be finite")
        if not np.all(np.isfinite(self.sigma)) or np.any(self.sigma < 0):
            raise InvalidParameterError("sigma", "must be finite and ≥ 0")

    def __len__(self) -> int:
        return len(self.ids)

    @classmethod
    def empty(cls) -> ReaderObjects:
        return cls(np.zeros(0, int), [], [], [], np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros(0))


#: species words meaning "genus known, species not" (GlobalArchive's ``spp``)
_NO_SPECIES = {"spp", "spp.", "sp", "sp."}


def _normalised_taxa(taxa: np.ndarray) -> np.ndarray:
    """(N, 3) object array of taxon names trimmed and case-folded, ``spp``/``sp.`` as a species not given."""
    out = np.array([[str(name).strip().casefold() for name in row] for row in taxa], dtype=object).reshape(-1, 3)
    if len(out):
        out[np.isin(out[:, 2], list(_NO_SPECIES)), 2] = ""
    return out


def _agree(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`taxa_agree` over broadcastable arrays of identifications (last axis: the three levels)."""
    given_a, given_b = a != "", b != ""
    shared = given_a & given_b
    consistent = shared.any(axis=-1) & np.all((a == b) | ~shared, axis=-1)
    return consistent | (~given_a.any(axis=-1) & ~given_b.any(axis=-1))


def taxa_agree(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) bool: whether identification ``a[i]`` agrees with ``b[j]`` (each (family, genus, species),
    '' where not given, normalised as :class:`ReaderObjects` holds them). They agree when they give at
    least one level in common and are equal on every level both give — family "Labridae" alone agrees
    with "Labridae Choerodon rubescens", two different families never agree, a family alone and a genus
    alone (no level in common) do not agree — or when neither gives any level (both unidentified)."""
    a, b = np.asarray(a, object).reshape(-1, 3), np.asarray(b, object).reshape(-1, 3)
    return _agree(a[:, None, :], b[None, :, :])


@dataclass(frozen=True)
class Agreement:
    """How two readers agree. Counts: ``n_a``, ``n_b`` objects, ``n_matched`` pairs; ``matched_share``
    = 2·matched / (n_a + n_b). Over the matched pairs, the differences a − b of the main figure (m):
    ``mean_difference``, ``sd_difference`` (sample SD), the Bland–Altman ``limits`` (mean ± 1.96 SD),
    ``share_within_sigma`` (|a − b| ≤ sqrt(σa² + σb²)), ``share_within_k`` (≤ k of those) and
    ``rms_normalised`` (root mean square of (a − b)/sqrt(σa² + σb²); near 1 when the σ are honest).
    ``species_agreement``: among objects paired on place and time alone (species ignored), the share whose
    identifications agree (:func:`taxa_agree`). NaN where there is nothing to compute it from."""

    n_a: int
    n_b: int
    n_matched: int
    matched_share: float
    mean_difference: float
    sd_difference: float
    limits: tuple[float, float]
    share_within_sigma: float
    share_within_k: float
    rms_normalised: float
    species_agreement: float
    n_species_compared: int


@dataclass(frozen=True)
class DoubleReading:
    """The comparison: ``pairs`` (M, 2) indices into reader A's and B's arrays, their ``difference`` (M,)
    a − b and ``combined_sigma`` (M,) m, ``flagged`` (M,) bool (|a − b| > k·combined σ), the indices of the
    objects of each reader left ``unmatched_a`` / ``unmatched_b``, ``species_conflicts`` (P, 2) indices of
    objects paired on place and time whose identifications disagree, and the :class:`Agreement`."""

    pairs: np.ndarray
    difference: np.ndarray
    combined_sigma: np.ndarray
    flagged: np.ndarray
    unmatched_a: np.ndarray
    unmatched_b: np.ndarray
    species_conflicts: np.ndarray
    agreement: Agreement
    k: float


def check_parameters(tolerance_s: float | None, gate_m: float, k: float,
                     tolerance_frames: float | None = None) -> None:
    """Refuse, by name, a tolerance (s or frames), gate (m) or k that is not a finite positive number
    (a tolerance may be 0), or a tolerance given both in seconds and in frames, or in neither."""
    if (tolerance_s is None) == (tolerance_frames is None):
        raise InvalidParameterError("tolerance_frames" if tolerance_frames is not None else "tolerance_s",
                                    "give the time tolerance in exactly one of seconds (tolerance_s) or frames "
                                    "(tolerance_frames)")
    tolerance = ("tolerance_s", tolerance_s) if tolerance_s is not None else ("tolerance_frames", tolerance_frames)
    why = {"gate_m": " (the largest distance between two readings of one object)",
           "k": " (how many combined σ a difference may reach)"}
    for name, value in (tolerance, ("gate_m", gate_m), ("k", k)):
        least = "≥ 0" if name == tolerance[0] else "> 0"  # (only a tolerance may be 0)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0 \
                or (least == "> 0" and value == 0):
            raise InvalidParameterError(name, f"must be a finite number {least}{why.get(name, '')}, got {value!r}")


def match_objects(a: ReaderObjects, b: ReaderObjects, tolerance_s: float | None, gate_m: float,
                  same_species: bool = True, tolerance_frames: float | None = None) -> np.ndarray:
    """(M, 2) indices of the pairs of ``a``'s and ``b``'s objects taken for the same object: same source and
    kind (and agreeing identifications, :func:`taxa_agree`, when ``same_species``), both instants known,
    times within ``tolerance_s`` s — or, with ``tolerance_s`` None, frames within ``tolerance_frames``
    frames — (both NaN: an image pair), midpoints within ``gate_m`` m; among the assignments that pair the
    most objects, the one with the smallest total midpoint distance. Sorted by a's index."""
    check_parameters(tolerance_s, gate_m, 1.0, tolerance_frames)
    if tolerance_s is None:
        instants_a, instants_b, tolerance = a.frame, b.frame, tolerance_frames
    else:
        instants_a, instants_b, tolerance = a.time_s, b.time_s, tolerance_s
    if not len(a) or not len(b):
        return np.zeros((0, 2), int)
    keys_a = list(zip(a.source, a.kind, strict=True))
    keys_b = list(zip(b.source, b.kind, strict=True))
    groups_b: dict[tuple, list[int]] = {}
    for j, key in enumerate(keys_b):
        groups_b.setdefault(key, []).append(j)
    groups_a: dict[tuple, list[int]] = {}
    for i, key in enumerate(keys_a):
        groups_a.setdefault(key, []).append(i)
    found = []
    for key, rows in groups_a.items():
        columns = groups_b.get(key)
        if not columns:
            continue
        ia, ib = np.array(rows), np.array(columns)
        distance = np.linalg.norm(a.midpoint[ia, None, :] - b.midpoint[None, ib, :], axis=2)
        ta, tb = instants_a[ia, None], instants_b[None, ib]
        # an image pair's objects: neither a time nor a frame (a video's object whose frame is unknown pairs
        # with none when the tolerance is in frames)
        both_untimed = (np.isnan(ta) & np.isnan(tb) & np.isnan(a.time_s[ia, None]) & np.isnan(b.time_s[None, ib]))
        with np.errstate(invalid="ignore"):
            same_instant = both_untimed | (np.abs(ta - tb) <= tolerance)
        known = a.instant_known[ia, None] & b.instant_known[None, ib]
        allowed = same_instant & known & (distance <= gate_m)
        if same_species:
            allowed &= taxa_agree(a.taxon[ia], b.taxon[ib])
        if not allowed.any():
            continue
        # a forbidden pair costs more than all allowed ones together, so the solver takes as few as it
        # can (the most pairs allowed), then the least total distance; the forbidden ones are dropped
        cost = np.where(allowed, distance, gate_m * (len(ia) + len(ib) + 1.0))
        rows_found, columns_found = linear_sum_assignment(cost)
        keep = allowed[rows_found, columns_found]
        found.append(np.column_stack([ia[rows_found[keep]], ib[columns_found[keep]]]))
    if not found:
        return np.zeros((0, 2), int)
    pairs = np.concatenate(found)
    return pairs[np.argsort(pairs[:, 0], kind="stable")]


def compare_readers(a: ReaderObjects, b: ReaderObjects, tolerance_s: float | None = 0.5, gate_m: float = 0.3,
                    k: float = 2.0, tolerance_frames: float | None = None) -> DoubleReading:
    """Pair the two readers' objects (:func:`match_objects`), flag the pairs whose main figures differ by
    more than ``k`` combined σ, list the unmatched ones and the species conflicts, and compute the
    :class:`Agreement`. ``tolerance_s`` s (or, with ``tolerance_s`` None, ``tolerance_frames`` frames),
    ``gate_m`` m, ``k`` dimensionless (default 2)."""
    check_parameters(tolerance_s, gate_m, k, tolerance_frames)
    pairs = match_objects(a, b, tolerance_s, gate_m, tolerance_frames=tolerance_frames)
    ia, ib = pairs[:, 0], pairs[:, 1]
    difference = a.value[ia] - b.value[ib]
    combined = np.hypot(a.sigma[ia], b.sigma[ib])
    with np.errstate(divide="ignore", invalid="ignore"):
        normalised = np.where(combined > 0, difference / np.where(combined > 0, combined, 1.0),
                              np.where(difference == 0, 0.0, np.inf))
    flagged = np.abs(normalised) > k
    unmatched_a = np.setdiff1d(np.arange(len(a)), ia)
    unmatched_b = np.setdiff1d(np.arange(len(b)), ib)
    placed = match_objects(a, b, tolerance_s, gate_m, same_species=False, tolerance_frames=tolerance_frames)
    agree = _agree(a.taxon[placed[:, 0]], b.taxon[placed[:, 1]]) if len(placed) else np.zeros(0, bool)
    conflicts = placed[~agree] if len(placed) else np.zeros((0, 2), int)
    n = len(pairs)
    mean = float(np.mean(difference)) if n else math.nan
    sd = float(np.std(difference, ddof=1)) if n > 1 else math.nan
    finite = normalised[np.isfinite(normalised)]
    agreement = Agreement(
        n_a=len(a), n_b=len(b), n_matched=n,
        matched_share=2 * n / (len(a) + len(b)) if len(a) + len(b) else math.nan,
        mean_difference=mean, sd_difference=sd,
        limits=(mean - LIMITS_Z * sd, mean + LIMITS_Z * sd),
        share_within_sigma=float(np.mean(np.abs(normalised) <= 1.0)) if n else math.nan,
        share_within_k=float(np.mean(~flagged)) if n else math.nan,
        rms_normalised=float(np.sqrt(np.mean(finite ** 2))) if len(finite) else math.nan,
        species_agreement=float(np.mean(agree)) if len(placed) else math.nan,
        n_species_compared=len(placed))
    return DoubleReading(pairs, difference, combined, flagged, unmatched_a, unmatched_b, conflicts, agreement,
                         float(k))
