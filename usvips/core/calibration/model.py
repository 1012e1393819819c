"""The stereo calibration model: named parameters → cameras at each station → computed pixels.

Parameters carry the seeds' symbols with ``_l`` / ``_r`` (ARCHITECTURE.md):

* interior, per camera: f, xp, yp, sy, k1, k2, p1, p2, k3 (pixels; sy, k dimensionless; k3 fixed at 0 unless freed);
* exterior at the first station (the object frame of the control): X0_l … kappa_l and X0_r … kappa_r;
  at every further station the left camera's pose ``X0_l@<pair>`` …, the right camera following it
  rigidly (the rig's relative orientation is the one of the first station);
* housing, in each camera's own frame (metres): the names its kind gives (``calibration_names`` of the
  kind's class in ``usvips/core/housing/kinds/``; ``_l``/``_r`` for one camera's, none for shared ones),
  built into the two housings by the kind (:meth:`Housing.build`);
* control coordinates ``X@<id>``, ``Y@<id>``, ``Z@<id>`` when the control file gives sigmas.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usvips.core import housing as housings
from usvips.core.adjustment import Observations, Parameter, Problem
from usvips.core.batch_mode import using_reference
from usvips.core.calibration.derivatives import stereo_derivatives
from usvips.core.calibration.parameter_names import (
    ORIGIN,
    build_housings,
    exterior_of,
    housing_parameter_names,
    interior_of,
    symbol,
)
from usvips.core.camera import EXTERIOR_PARAMETERS, Camera, Exterior
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.interior import INTERIOR_PARAMETERS
from usvips.core.intersection import pixel_jacobian
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import relative_orientation, right_exterior
from usvips.core.rotation import rotation_matrix

SIDES = ("l", "r")
#: a camera at the origin of its own frame: the batched paths carry points into each camera's frame
_STEPS = {"f": 1e-3, "xp": 1e-3, "yp": 1e-3, "sy": 1e-7, "k1": 1e-7, "k2": 1e-7, "p1": 1e-8, "p2": 1e-8, "k3": 1e-7,
          "X0": 1e-6, "Y0": 1e-6, "Z0": 1e-6, "omega": 1e-7, "phi": 1e-7, "kappa": 1e-7,
          "X": 1e-6, "Y": 1e-6, "Z": 1e-6}


def stereo_cameras(kind: str, values: dict[str, float], stations: tuple[str, ...], station: str,
                   size: tuple[int | None, int | None] = (None, None), frame: str = "object",
                   shared: dict | None = None) -> tuple[Camera, Camera]:
    """The two cameras at ``station`` from named parameter values (see the module docstring).

    frame ``object``: placed in the control frame; ``rig``: the left camera at the origin with its own
    axes, the right one by the relative orientation of the first station. ``shared``: a dict that keeps
    what every station of one set of values has in common (the housings, the relative orientation) for
    the next call with the same values."""
    shared = {} if shared is None else shared
    left_0, right_0 = exterior_of(values, "l"), exterior_of(values, "r")
    if frame == "rig" or station != stations[0]:
        if "relative" not in shared:
            shared["relative"] = relative_orientation(left_0, right_0)
        relative = shared["relative"]
    if frame == "rig":
        left = Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        right = right_exterior(left, relative)
    elif station == stations[0]:
        left, right = left_0, right_0
    else:
        left = exterior_of(values, "l", station)
        right = right_exterior(left, relative)
    if "housings" not in shared:
        shared["housings"] = build_housings(kind, values)
    housing_l, housing_r = shared["housings"]
    width, height = size
    return (Camera(interior_of(values, "l"), left, housing_l, width, height),
            Camera(interior_of(values, "r"), right, housing_r, width, height))


@dataclass
class StereoModel:
    """A calibration problem: control, observations (with their pair labels = stations), housing kind."""

    kind: str
    control: ControlPoints
    observations: StereoObservations
    sigma_px: float = 0.5
    size: tuple[int | None, int | None] = (None, None)
    stations: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        self.housing_kind = housings.kind(self.kind)
        self.stations = self.observations.pair_labels
        self._index = self.control.index_of(list(self.observations.ids), "observation")
        self.control_parameters = self.control.sigmas is not None and bool(np.any(self.control.sigmas > 0))
        # observation layout: blocks (station, side); in each block x0, y0, x1, y1, ...
        self.block_keys: list[tuple[str, str]] = []
        self.block_rows: list[np.ndarray] = []
        values, point, side_l, coord, group, blocks = [], [], [], [], [], []
        offset = 0
        rows_of: dict[str, list[int]] = {}
        for i, pair in enumerate(self.observations.pairs):  # one pass: linear in the observations
            rows_of.setdefault(pair, []).append(i)
        for station in self.stations:
            rows = np.array(rows_of.get(station, []), dtype=int)
            for side in SIDES:
                pixels = (self.observations.left if side == "l" else self.observations.right)[rows]
                values.append(pixels.reshape(-1))
                count = 2 * len(rows)
                blocks.append(np.arange(offset, offset + count))
                offset += count
                self.block_keys.append((station, side))
                self.block_rows.append(rows)
                for r in rows:
                    for c in ("x", "y"):
                        point.append(self.observations.ids[r])
                        side_l.append(side)
                        coord.append(c)
                        group.append(station)
        values = np.concatenate(values)
        self._warm: dict[int, np.ndarray] = {}
        #: per side (left, right): whether its exact derivatives took their rays from the points at the last
        #: Jacobian (an observation no ray reaches: see ``derivatives._side_rays``), and so start there again
        self.rays_from_points = [False, False]
        # per block: its station's place, its side's, and the control rows of its points (batched paths)
        self.block_station = np.array([self.stations.index(s) for s, _ in self.block_keys], dtype=int)
        self.block_side = np.array([SIDES.index(side) for _, side in self.block_keys], dtype=int)
        self.block_points = [self._index[rows] for rows in self.block_rows]
        self._pose_names = [[f"{p}_l" if k == 0 else f"{p}_l@{s}" for k, s in enumerate(self.stations)]
                            for p in EXTERIOR_PARAMETERS]
        self.observation_set = Observations(values, np.full(len(values), float(self.sigma_px)), point, side_l,
                                            coord, group)
        self.blocks = blocks

    # ---------------------------------------------------------------------------------- cameras
    def control_xyz(self, values: dict[str, float]) -> np.ndarray:
        xyz = self.control.xyz.copy()
        if self.control_parameters:
            for i, pid in enumerate(self.control.ids):
                for k, axis in enumerate("XYZ"):
                    name = f"{axis}@{pid}"
                    if name in values:
                        xyz[i, k] = values[name]
        return xyz

    def cameras(self, values: dict[str, float], station: str | None = None,
                bounded: bool = True, shared: dict | None = None) -> tuple[Camera, Camera]:
        """The two cameras at a station (default: the first) for the given parameter values; ``bounded``
        gives them the image size (the adjustment itself does not clip at the frame); ``shared``: see
        :func:`stereo_cameras` (one dict per set of values)."""
        return stereo_cameras(self.kind, values, self.stations, station or self.stations[0],
                              self.size if bounded else (None, None), shared=shared)

    def station_frames(self, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """Every station's camera rotations M (object → image) and perspective centres C (metres), both
        sides at once: M (stations, 2, 3, 3), C (stations, 2, 3), side 0 left, 1 right. The first
        station's cameras have their own poses; a further station's right camera follows the rig:
        M_r = M_rel M_l, C_r = C_l + M_lᵀ b with M_rel = M_r0 M_l0ᵀ and b = M_l0 (C_r0 − C_l0)."""
        pose = np.array([[values[n] for n in names] for names in self._pose_names])  # (6, stations)
        m_l = rotation_matrix(pose[3], pose[4], pose[5])
        c_l = pose[:3].T
        m_r0 = rotation_matrix(*(values[f"{p}_r"] for p in ("omega", "phi", "kappa")))
        c_r0 = np.array([values[f"{p}_r"] for p in ("X0", "Y0", "Z0")])
        m_rel = m_r0 @ m_l[0].T
        base = m_l[0] @ (c_r0 - c_l[0])
        m = np.empty((len(self.stations), 2, 3, 3))
        c = np.empty((len(self.stations), 2, 3))
        m[:, 0], c[:, 0] = m_l, c_l
        m[:, 1] = m_rel @ m_l
        c[:, 1] = c_l + np.einsum("sji,j->si", m_l, base)
        m[0, 1], c[0, 1] = m_r0, c_r0
        return m, c

    def evaluate(self, values: dict[str, float], blocks=None) -> tuple[np.ndarray, np.ndarray]:
        """Computed pixels of the observations (all, or of the given blocks, concatenated in block order),
        and a validity mask.

        One back-projection per side: the housing sits in the camera frame and the interior is the same
        at every station, so each block's points are carried into its own camera frame, concatenated and
        back-projected at once (:meth:`_evaluate_side`). Under :func:`usvips.core.batch_mode.reference` each
        block is projected by its own camera (:meth:`_evaluate_per_block`, the reference path)."""
        if using_reference():
            return self._evaluate_per_block(values, blocks)
        chosen = list(range(len(self.blocks))) if blocks is None else list(blocks)
        pieces: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(chosen)
        try:
            m, c = self.station_frames(values)
            housings_lr = build_housings(self.kind, values)
            interiors = (interior_of(values, "l"), interior_of(values, "r"))
        except UsvipsError:  # impossible parameters at a trial step (e.g. r <= 0): reject the step
            m = None
        for side in (0, 1):
            mine = [k for k, b in enumerate(chosen) if self.block_side[b] == side]
            if not mine:
                continue
            picked = [chosen[k] for k in mine]
            results = None
            if m is not None:
                try:
                    results = self._evaluate_side(values, picked, m, c, interiors[side], housings_lr[side], side)
                except UsvipsError:
                    results = None
            for k, b in zip(mine, picked, strict=True):
                n = len(self.blocks[b])
                pieces[k] = results[b] if results is not None else (np.zeros(n), np.zeros(n, dtype=bool))
        if not pieces:
            return np.zeros(0), np.zeros(0, dtype=bool)
        return np.concatenate([p[0] for p in pieces]), np.concatenate([p[1] for p in pieces])

    def _evaluate_side(self, values, blocks, m, c, interior, housing, side) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """The pixels of ``blocks`` (all of one side) in one back-projection through that side's camera
        at the origin of its own frame; {block: (pixels (2N,), validity (2N,))}."""
        xyz = self.control_xyz(values)
        counts = [len(self.block_points[b]) for b in blocks]
        points = xyz[np.concatenate([self.block_points[b] for b in blocks])]
        which = np.repeat(self.block_station[blocks], counts)
        local = np.einsum("nij,nj->ni", m[which, side], points - c[which, side])
        warm = None
        if all(b in self._warm for b in blocks):
            warm = np.vstack([self._warm[b] for b in blocks])
        camera = Camera(interior, ORIGIN, housing)
        projection = camera.project(local, warm)
        valid = projection.status == 0
        ends = np.cumsum([0, *counts])
        out = {}
        for k, b in enumerate(blocks):
            rows = slice(ends[k], ends[k + 1])
            self._warm[b] = np.where(valid[rows, None], projection.pixels[rows], np.nan)
            out[b] = (projection.pixels[rows].reshape(-1), np.repeat(valid[rows], 2))
        return out

    def _evaluate_per_block(self, values: dict[str, float], blocks=None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`evaluate` block by block, each block's camera built and projecting on its own."""
        chosen = range(len(self.blocks)) if blocks is None else blocks
        xyz = self.control_xyz(values)
        out, ok = [], []
        cache: dict[str, tuple[Camera, Camera]] = {}
        shared: dict = {}  # the housings and the relative orientation, built once for every station
        for b in chosen:
            station, side = self.block_keys[b]
            try:
                if station not in cache:
                    cache[station] = self.cameras(values, station, bounded=False, shared=shared)
                camera = cache[station][0 if side == "l" else 1]
                # start from this block's last answer: parameters change little between evaluations
                projection = camera.project(xyz[self._index[self.block_rows[b]]], self._warm.get(b))
                valid = projection.status == 0
                self._warm[b] = np.where(valid[:, None], projection.pixels, np.nan)
                out.append(projection.pixels.reshape(-1))
                ok.append(np.repeat(valid, 2))
            except UsvipsError:  # impossible parameters at a trial step (e.g. r <= 0): reject the step
                n = len(self.blocks[b])
                out.append(np.zeros(n))
                ok.append(np.zeros(n, dtype=bool))
        return np.concatenate(out), np.concatenate(ok)

    # ---------------------------------------------------------------------------------- parameters
    def parameter_names(self) -> list[str]:
        names = [f"{p}_{s}" for s in SIDES for p in INTERIOR_PARAMETERS]
        names += [f"{p}_{s}" for s in SIDES for p in EXTERIOR_PARAMETERS]
        for station in self.stations[1:]:
            names += [f"{p}_l@{station}" for p in EXTERIOR_PARAMETERS]
        names += housing_parameter_names(self.kind)
        if self.control_parameters:
            for pid in self.control.ids:
                names += [f"{axis}@{pid}" for axis in "XYZ"]
        return names

    def dependencies(self) -> dict[str, list[int]]:
        """Which observation blocks each parameter influences (for a cheap numerical Jacobian)."""
        blocks_of = {key: i for i, key in enumerate(self.block_keys)}
        first = self.stations[0]
        all_blocks = list(range(len(self.blocks)))
        right_blocks = [i for i, (_, s) in enumerate(self.block_keys) if s == "r"]
        depends: dict[str, list[int]] = {}
        housing_names = set(self.housing_kind.calibration_names)
        for name in self.parameter_names():
            base = name.split("@")[0]
            station = name.split("@")[1] if "@" in name and base in {f"{p}_l" for p in EXTERIOR_PARAMETERS} else None
            if name in housing_names:
                side = self.housing_kind.side_of(name)
                depends[name] = (all_blocks if side is None
                                 else [i for i, (_, s) in enumerate(self.block_keys) if s == side])
            elif base in {f"{p}_l" for p in INTERIOR_PARAMETERS}:
                depends[name] = [i for i, (_, s) in enumerate(self.block_keys) if s == "l"]
            elif base in {f"{p}_r" for p in INTERIOR_PARAMETERS}:
                depends[name] = right_blocks
            elif station is not None:
                depends[name] = [blocks_of[(station, "l")], blocks_of[(station, "r")]]
            elif base in {f"{p}_l" for p in EXTERIOR_PARAMETERS}:
                # the first station's left pose places the left camera there and, through the relative
                # orientation, every right camera (and, for a shared cover plane, every right housing);
                # the first station's right camera has its own pose, so only a right housing that follows
                # the rig makes it depend on the left one's
                moved = {blocks_of[(first, "l")], *right_blocks}
                if not self.housing_kind.right_follows_rig:
                    moved.discard(blocks_of[(first, "r")])
                depends[name] = sorted(moved)
            elif base in {f"{p}_r" for p in EXTERIOR_PARAMETERS}:
                depends[name] = right_blocks
            else:
                depends[name] = all_blocks
        return depends

    def problem(self, parameters: list[Parameter]) -> Problem:
        names = {p.name for p in parameters}
        missing = [n for n in self.parameter_names() if n not in names]
        if missing:
            raise DegenerateGeometryError(f"no value for parameter(s) {', '.join(missing[:6])}")
        housing_names = set(self.housing_kind.calibration_names)
        for p in parameters:
            p.step = (self.housing_kind.spec(symbol(p.name)).step if p.name in housing_names
                      else _STEPS.get(symbol(p.name), 1e-6))
        free = frozenset(p.name for p in parameters if p.status != "fixed")

        def evaluate(values, blocks):
            return self.evaluate(values, blocks)

        return Problem(parameters, self.observation_set, evaluate, self.blocks, self.dependencies(),
                       analytic=lambda values, computed: stereo_derivatives(self, values, computed, free))

    def exterior_derivatives(self, values: dict[str, float], computed: np.ndarray) -> dict[str, dict[int, np.ndarray]]:
        """Exact derivatives of each block's pixels with respect to its own camera's exterior orientation.

        One ray trace with forward-mode derivatives per block gives ∂pixel/∂X for every point (the pixel
        Jacobian of the intersection); a shift of the perspective centre moves the point the other way,
        and a rotation turns it about the centre: ∂p/∂angle = (∂p/∂X) Mᵀ (∂M/∂angle)(X − X0).
        Where a camera's housing also moves with its exterior (the right camera under System I's shared
        plane) or the camera follows the rig (the right camera at further stations), differences remain.
        """
        xyz = self.control_xyz(values)
        out: dict[str, dict[int, np.ndarray]] = {}
        first = self.stations[0]
        for b, (station, side) in enumerate(self.block_keys):
            # the right camera further on follows the rig; under a shared cover plane its housing moves
            # with the relative orientation too: those keep their differences
            if side == "r" and (station != first or self.housing_kind.right_follows_rig):
                continue
            suffix = f"_{side}" + ("" if station == first else f"@{station}")
            rows = self.blocks[b]
            pixels = computed[rows].reshape(-1, 2)
            if not np.all(np.isfinite(pixels)):
                continue
            try:
                camera = self.cameras(values, station, bounded=False)[0 if side == "l" else 1]
                bundle, d_origin, d_direction = camera.rays_with_derivatives(pixels)
            except UsvipsError:
                continue
            if not bundle.ok.all():
                continue
            points = xyz[self._index[self.block_rows[b]]]
            along = np.einsum("ij,ij->i", points - bundle.origins, bundle.directions)
            a0, a1, valid = pixel_jacobian(bundle.directions, d_origin, d_direction, along)
            if not valid.all():
                continue
            exterior = camera.exterior
            relative = points - exterior.position
            columns = {}
            for k, name in enumerate(("X0", "Y0", "Z0")):
                columns[name] = (-a0[:, k], -a1[:, k])
            m = exterior.rotation
            for name in ("omega", "phi", "kappa"):
                h = 1e-7
                angles = {"omega": exterior.omega, "phi": exterior.phi, "kappa": exterior.kappa}
                ahead, behind = dict(angles), dict(angles)
                ahead[name] += h
                behind[name] -= h
                d_m = (rotation_matrix(**ahead) - rotation_matrix(**behind)) / (2 * h)
                moved = relative @ d_m.T @ m  # Mᵀ (∂M/∂angle)(X − X0), as rows
                columns[name] = (np.einsum("ij,ij->i", a0, moved), np.einsum("ij,ij->i", a1, moved))
            for name, (dx, dy) in columns.items():
                column = np.empty(2 * len(points))
                column[0::2], column[1::2] = dx, dy
                out.setdefault(f"{name}{suffix}", {})[b] = column
        return out
