"""Do a project's stated σ hold? A Monte Carlo of the project's own geometry.

Each object's measured vertices are taken as the truth. A replica draws what the measurement did not
know: the calibration's error — its free parameters drawn from their a-posteriori covariance (the "true"
cameras; none drawn where a calibration has no covariance) — and each pick's error, a Gaussian of the
pointing σ believed true for it (``pointing_px``, per vertex and image). The truth is projected through
the drawn cameras, the noise added, and the pixels intersected with the calibration's own cameras, as the
project measures them; the object's main figure follows from its kind's formula. Its normalised error
e = (value − truth) / σ_stated uses the σ the project states for it (from the one figure function); the
mean of e² is the NEES: 1 when the stated σ hold, above 1 when they are too small.

Nothing is linearised: the projection, the refraction, the intersection and the figure are the full
nonlinear ones, so the check also catches a first-order σ that fails (long ranges, short lengths, the
edge of a dome). One calibration draw is common to every object measured with it (as in the project),
so objects are not independent: the NEES of a kind is the mean over replicas of each replica's mean e²,
and its 95 % interval is Student's t over the replicas.

Conventions: metres, pixels (one image coordinate), the main figure in its kind's unit.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from usvips.core.calibration.model import stereo_cameras
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.intersection import intersect
from usvips.core.measurements.registry import kind as kind_named
from usvips.core.rays import RayStatus
from usvips.core.stereo_calibration import StereoCalibration

#: the NEES band in which stated σ are taken to hold (the project's acceptance band)
HOLDS = (0.7, 1.5)
#: replicas a check draws by default
REPLICAS = 40


class SigmaCheckCancelled(UsvipsError):
    """The check stopped because it was cancelled."""


@dataclass(frozen=True)
class CheckGeometry:
    """Where a group of objects was measured: a calibration at ``station`` in ``frame``."""

    calibration: StereoCalibration
    station: int | str = 0
    frame: str = "object"


@dataclass(frozen=True)
class CheckedObject:
    """One object to check: its ``kind``, its measured vertices ``points`` (N, 3) m (taken as the truth),
    the ``sigma`` its main figure is stated with (the kind's unit), the index ``geometry`` of its
    :class:`CheckGeometry`, and ``pointing_px`` (N, 2): the pointing σ (px, one coordinate) of each
    vertex's left and right pick believed true, which the replicas draw."""

    id: str
    kind: str
    points: np.ndarray
    sigma: float
    geometry: int
    pointing_px: np.ndarray


@dataclass(frozen=True)
class KindCheck:
    """The check of one kind: ``objects`` checked over ``replicas``; ``nees`` and its 95 % interval
    ``low``..``high``; ``worst``: the id of the object with the largest mean e² and that mean;
    ``skipped``: objects some replica could not measure (a drawn camera does not see a vertex; they count
    in the replicas that could)."""

    kind: str
    objects: int
    replicas: int
    nees: float
    low: float
    high: float
    worst: tuple[str, float]
    skipped: int = 0

    @property
    def verdict(self) -> str:
        """'hold', 'too small' (the stated σ understate the error) or 'too large'."""
        if self.nees > HOLDS[1]:
            return "too small"
        return "too large" if self.nees < HOLDS[0] else "hold"


@dataclass(frozen=True)
class SigmaCheck:
    """The check's rows, one per kind in the registry's order, and the replicas drawn."""

    kinds: tuple[KindCheck, ...]
    replicas: int


def _draw_cameras(geometry: CheckGeometry, rng: np.random.Generator, tries: int = 20):
    """The two "true" cameras of one replica: the calibration's parameters with a draw of their covariance
    (the calibration's own cameras when it has none)."""
    calibration = geometry.calibration
    base = calibration.rig(geometry.station, geometry.frame)
    if calibration.covariance is None:
        return base.left, base.right
    names, sigma = calibration.covariance
    if not all(name in calibration.parameters for name in names):
        return base.left, base.right
    values = {name: p.value for name, p in calibration.parameters.items()}
    eigen, vectors = np.linalg.eigh(np.asarray(sigma, dtype=np.float64))
    root = vectors * np.sqrt(np.clip(eigen, 0.0, None))
    label = calibration.stations[calibration.station_index(geometry.station)]
    size = (calibration.left.width, calibration.left.height)
    for _ in range(tries):
        delta = root @ rng.standard_normal(len(names))
        drawn = dict(values)
        for name, d in zip(names, delta, strict=True):
            drawn[name] += float(d)
        try:
            return stereo_cameras(calibration.left.housing.kind, drawn, calibration.stations, label, size,
                                  geometry.frame)
        except UsvipsError:
            continue  # a draw outside the valid region (e.g. a dome's centre behind its cover): draw again
    raise UsvipsError("the calibration's covariance draws no valid cameras: it is too large to check")


def _main_values(kind: str, stack: np.ndarray) -> np.ndarray:
    """The main figure of each vertex set of a stack (M, N, 3) of one kind (NaN where degenerate)."""
    measurement_kind = kind_named(kind)
    index = [name for name, _ in measurement_kind.figure_names].index(measurement_kind.main_name())
    if measurement_kind.values_many is not None and len(stack):
        good = np.all(np.isfinite(stack.reshape(len(stack), -1)), axis=1)
        out = np.full(len(stack), np.nan)
        if good.any():
            try:
                out[good] = np.asarray(measurement_kind.values_many(stack[good]))[:, index]
                return out
            except UsvipsError:
                pass  # a degenerate set among them: one by one below
    out = np.full(len(stack), np.nan)
    for i, points in enumerate(stack):
        if np.all(np.isfinite(points)):
            try:
                out[i] = float(np.asarray(measurement_kind.values(points))[index])
            except UsvipsError:
                pass
    return out


def check_sigmas(objects: Sequence[CheckedObject], geometries: Sequence[CheckGeometry], replicas: int = REPLICAS,
                 seed: int = 0, cancel: Callable[[], bool] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> SigmaCheck:
    """The Monte Carlo of the module docstring over ``replicas`` draws (seeded by ``seed``: the same
    check gives the same figures). ``cancel`` is asked between replicas (a :class:`SigmaCheckCancelled`
    when it turns true), ``progress`` told (replicas done, replicas)."""
    if int(replicas) < 2:
        raise InvalidParameterError("replicas", f"must be at least 2, got {replicas}")
    if not objects:
        raise InvalidParameterError("objects", "none to check: the project has no measured object with figures")
    replicas = int(replicas)
    rng = np.random.default_rng(seed)
    groups: dict[tuple[int, str, int], list[int]] = {}
    for i, o in enumerate(objects):
        if not 0 <= o.geometry < len(geometries):
            raise InvalidParameterError("geometry", f"object {o.id}: no geometry {o.geometry}")
        if not np.isfinite(o.sigma) or o.sigma <= 0:
            raise InvalidParameterError("sigma", f"object {o.id}: stated σ {o.sigma:g} is not positive")
        groups.setdefault((o.geometry, o.kind, len(o.points)), []).append(i)
    truth = {key: _main_values(key[1], np.stack([objects[i].points for i in members]))
             for key, members in groups.items()}
    stated = np.array([o.sigma for o in objects])
    squares = np.full((replicas, len(objects)), np.nan)
    for r in range(replicas):
        if cancel is not None and cancel():
            raise SigmaCheckCancelled("the σ check was cancelled")
        for g, geometry in enumerate(geometries):
            keys = [key for key in groups if key[0] == g]
            if not keys:
                continue
            drawn = _draw_cameras(geometry, rng)
            rig = geometry.calibration.rig(geometry.station, geometry.frame)
            for key in keys:
                members = groups[key]
                points = np.concatenate([objects[i].points for i in members])
                sigma = np.concatenate([objects[i].pointing_px for i in members])
                pixels = []
                seen = np.ones(len(points), bool)
                for side, camera in enumerate(drawn):
                    projection = camera.project(points)
                    seen &= projection.status == RayStatus.OK
                    pixels.append(projection.pixels + rng.standard_normal((len(points), 2)) * sigma[:, side, None])
                measured = np.full(points.shape, np.nan)
                if seen.any():
                    result = intersect([rig.left, rig.right], [pixels[0][seen], pixels[1][seen]])
                    measured[seen] = np.where(result.ok[:, None], result.points, np.nan)
                values = _main_values(key[1], measured.reshape(len(members), key[2], 3))
                squares[r, members] = ((values - truth[key]) / stated[members]) ** 2
        if progress is not None:
            progress(r + 1, replicas)
    from scipy import stats  # deferred: slow to import

    rows = []
    order = {name: i for i, name in enumerate(_kind_order())}
    for kind in sorted({o.kind for o in objects}, key=lambda k: order.get(k, len(order))):
        members = [i for i, o in enumerate(objects) if o.kind == kind]
        block = squares[:, members]
        measured = np.isfinite(block)
        # an object some replica could not measure (a drawn camera does not see a vertex) counts where it
        # could; one no replica measured is left out
        seen = measured.any(axis=0)
        if not seen.any():
            continue
        block = block[:, seen]
        per_replica = np.nanmean(block, axis=1)
        nees = float(np.nanmean(per_replica))
        half = float(stats.t.ppf(0.975, replicas - 1) * np.nanstd(per_replica, ddof=1) / np.sqrt(replicas))
        per_object = np.nanmean(block, axis=0)
        worst = int(np.argmax(per_object))
        rows.append(KindCheck(kind, int(seen.sum()), replicas, nees, max(nees - half, 0.0), nees + half,
                              (objects[np.asarray(members)[seen][worst]].id, float(per_object[worst])),
                              int(np.sum(~measured.all(axis=0)))))
    return SigmaCheck(tuple(rows), replicas)


def _kind_order() -> tuple[str, ...]:
    from usvips.core.measurements.registry import names

    return names()
