"""Exact derivatives of a stereo calibration's computed pixels, block by block (the survey-size engine).

A calibration's Jacobian has a structure: each observation block (one camera at one station) depends on
that camera's interior (9 parameters), its pose at the station (6 parameters, or, for a right camera that
follows the rig, the 18 that compose it), its housing, and the control points it sees. Differentiating
every column by re-tracing every point of every block it touches (the reference path:
:func:`usvips.core.adjustment._jacobian`, forward differences) costs one back-projection per parameter and
block. Here one ray trace with forward-mode derivatives per block gives every column but the housing's:

* **interior** — the pixel is ``x = xp + f·ud``, ``y = yp − f·vd/sy`` of the distorted ideal coordinates
  (ud, vd) of the ray's ideal normalised coordinates (u, v), which the interior does not move (the housing
  back-projection happens in the camera frame). Closed form, no trace at all.
* **pose** — a parameter θ that moves the camera (its own exterior, or through the relative orientation
  the rig's right camera) moves its pixels as the object point would move by
  dP = Mᵀ (∂M/∂θ)(P − C) − ∂C/∂θ (M the object → image rotation, C the perspective centre). dP enters
  through ∂pixel/∂P, the pixel Jacobian of the traced ray (:func:`usvips.core.intersection.pixel_jacobian`).
  ∂M/∂θ and ∂C/∂θ follow from the pose composition (3 × 3 matrices, no trace) with ∂M/∂angle by
  central differences of the rotation matrix (error ~1e-12 relative).

* **housing** — a housing parameter h moves the ray a fixed pixel traces: by ∂o/∂h + s ∂d/∂h at the point's
  distance s along it. The point is then reached by the pixel that moved by −(∂pixel/∂P)·(∂o/∂h + s ∂d/∂h).
  ∂o/∂h and ∂d/∂h are central differences of the forward trace of the block's pixels through the housing
  rebuilt at h ± step (closed-form refractions, no back-projection; error ~1e-10 relative). Only the free
  parameters that change this camera's housing get a column. The housing sits in the camera frame and
  the interior is the camera's at every station, so each side's pixels of all stations are traced in one
  batch per shifted housing from their ideal directions (u, v, −1), and each block's ray motion is turned
  into the object frame by its own rotation (:func:`side_housing_columns`; the per-block traces of
  :func:`housing_columns` are the reference path, under :func:`usvips.core.batch_mode.reference`).

Under System I's shared cover plane the first station's poses also move the right camera's housing (it
follows the rig's relative orientation): those right-camera columns are the camera's motion (as above)
plus the housing's, formed as the housing columns are, with the housings rebuilt at each pose parameter
± step. A block or column this cannot give (a ray failing, a step leaving the valid region) is left to the
reference path's differences: the solver differentiates what this returns no column for. Units: pixels
per parameter unit (metres, radians, pixels, dimensionless).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usvips.core import kernels
from usvips.core.batch_mode import using_reference
from usvips.core.calibration.parameter_names import ORIGIN, build_housings, housing_parameter_names, interior_of
from usvips.core.errors import UsvipsError
from usvips.core.interior import INTERIOR_PARAMETERS
from usvips.core.intersection import pixel_jacobian
from usvips.core.rays import RayStatus
from usvips.core.rotation import rotation_matrix

#: central-difference step of the pose composition (metres for positions, radians for angles)
POSE_STEP = 1e-6
#: central-difference step of a housing parameter (metres; refractive indices: dimensionless)
HOUSING_STEP = 1e-6

Columns = dict[str, dict[int, np.ndarray]]


def interior_columns(interior, uv: np.ndarray) -> dict[str, np.ndarray]:
    """∂pixel/∂(f, xp, yp, sy, k1, k2, p1, p2, k3) at ideal normalised coordinates ``uv`` (N, 2): each an
    interleaved column (2N,) x0, y0, x1, y1, … in pixels per unit of the parameter."""
    u, v = uv[:, 0], uv[:, 1]
    r2 = u * u + v * v
    radial = interior.k1 * r2 + (interior.k2 + interior.k3 * r2) * r2 * r2
    ud = u + u * radial + interior.p1 * (r2 + 2 * u * u) + 2 * interior.p2 * u * v
    vd = v + v * radial + interior.p2 * (r2 + 2 * v * v) + 2 * interior.p1 * u * v
    f, sy = interior.f, interior.sy
    zero, one = np.zeros_like(u), np.ones_like(u)
    r4 = r2 * r2
    pairs = {
        "f": (ud, -vd / sy),
        "xp": (one, zero),
        "yp": (zero, one),
        "sy": (zero, f * vd / (sy * sy)),
        "k1": (f * u * r2, -f * v * r2 / sy),
        "k2": (f * u * r4, -f * v * r4 / sy),
        "k3": (f * u * r4 * r2, -f * v * r4 * r2 / sy),
        "p1": (f * (r2 + 2 * u * u), -f * 2 * u * v / sy),
        "p2": (f * 2 * u * v, -f * (r2 + 2 * v * v) / sy),
    }
    return {name: _interleave(*pairs[name]) for name in INTERIOR_PARAMETERS}


def _interleave(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    column = np.empty(2 * len(dx))
    column[0::2], column[1::2] = dx, dy
    return column


ANGLES = ("omega", "phi", "kappa")


def _rotation_and_derivatives(values: dict[str, float], suffix: str, cache: dict | None = None
                              ) -> tuple[np.ndarray, list[np.ndarray]]:
    """M(omega, phi, kappa) of the named camera and ∂M/∂angle for each angle (central differences);
    ``cache`` (suffix → result) keeps them for the other blocks of one Jacobian."""
    if cache is not None:
        if suffix not in cache:
            cache[suffix] = _rotation_and_derivatives(values, suffix)
        return cache[suffix]
    angles = [values[f"{a}{suffix}"] for a in ANGLES]
    derivatives = []
    for k in range(3):
        ahead, behind = list(angles), list(angles)
        ahead[k] += POSE_STEP
        behind[k] -= POSE_STEP
        derivatives.append((rotation_matrix(*ahead) - rotation_matrix(*behind)) / (2 * POSE_STEP))
    return rotation_matrix(*angles), derivatives


def _centre(values: dict[str, float], suffix: str) -> np.ndarray:
    return np.array([values[f"{p}{suffix}"] for p in ("X0", "Y0", "Z0")])


def pose_derivatives(values: dict[str, float], station: str, side: str, first: str, cache: dict | None = None
                     ) -> tuple[np.ndarray, np.ndarray, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """The camera's rotation M and centre C at ``station`` and ``{parameter: (∂M/∂θ, ∂C/∂θ)}`` for every
    parameter of its pose. The first station's cameras have their own parameters; a further station's
    left camera has ``…_l@station``; the right camera there follows the rig (as
    :func:`usvips.core.rig.right_exterior` composes it):
    M = M_r0 M_l0ᵀ M_ls, C = C_ls + M_lsᵀ M_l0 (C_r0 − C_l0). ``cache``: see :func:`_rotation_and_derivatives`."""
    unit = np.eye(3)
    zero_m, zero_c = np.zeros((3, 3)), np.zeros(3)
    own = f"_{side}" if station == first else f"_l@{station}"
    m_own, d_own = _rotation_and_derivatives(values, own, cache)
    c_own = _centre(values, own)
    if station == first or side == "l":
        columns = {f"{p}{own}": (zero_m, unit[k]) for k, p in enumerate(("X0", "Y0", "Z0"))}
        columns.update({f"{a}{own}": (d_own[k], zero_c) for k, a in enumerate(ANGLES)})
        return m_own, c_own, columns
    m_l0, d_l0 = _rotation_and_derivatives(values, "_l", cache)
    m_r0, d_r0 = _rotation_and_derivatives(values, "_r", cache)
    c_l0, c_r0 = _centre(values, "_l"), _centre(values, "_r")
    gap = c_r0 - c_l0
    base = m_l0 @ gap
    m_rel = m_r0 @ m_l0.T
    carry = m_own.T @ m_l0  # object-frame gap → the right centre's offset at this station
    columns = {}
    for k, p in enumerate(("X0", "Y0", "Z0")):
        columns[f"{p}{own}"] = (zero_m, unit[k])
        columns[f"{p}_l"] = (zero_m, -carry[:, k])
        columns[f"{p}_r"] = (zero_m, carry[:, k])
    for k, a in enumerate(ANGLES):
        columns[f"{a}{own}"] = (m_rel @ d_own[k], d_own[k].T @ base)
        columns[f"{a}_l"] = (m_r0 @ d_l0[k].T @ m_own, m_own.T @ (d_l0[k] @ gap))
        columns[f"{a}_r"] = (d_r0[k] @ m_l0.T @ m_own, zero_c)
    return m_rel @ m_own, c_own + m_own.T @ base, columns


def pose_columns(m: np.ndarray, c: np.ndarray, derivatives: dict[str, tuple[np.ndarray, np.ndarray]],
                 a0: np.ndarray, a1: np.ndarray, points: np.ndarray) -> dict[str, np.ndarray]:
    """∂pixel/∂θ for each pose parameter θ: the equivalent object-point motion
    dP = Mᵀ (∂M/∂θ)(P − C) − ∂C/∂θ through the pixel Jacobian rows ``a0``, ``a1`` (N, 3).

    All parameters at once: a·dP = Σ_ij a_j (P − C)_i T_θ[i, j] − a·∂C/∂θ with T_θ = (Mᵀ ∂M/∂θ)ᵀ, one
    (N, 9) × (9, k) product per pixel coordinate."""
    if not derivatives:
        return {}
    names = list(derivatives)
    turns = np.stack([(m.T @ derivatives[n][0]).T for n in names]).reshape(len(names), 9)
    shifts = np.stack([derivatives[n][1] for n in names])
    relative = points - c
    columns = np.empty((2 * len(points), len(names)))
    for k, a in enumerate((a0, a1)):
        outer = (relative[:, :, None] * a[:, None, :]).reshape(-1, 9)
        columns[k::2] = outer @ turns.T - a @ shifts.T
    return {name: columns[:, j] for j, name in enumerate(names)}


def _shifted_housings(model, values: dict[str, float], free: frozenset[str] | None) -> tuple[dict, list[str]]:
    """The housings at ``values`` (key None) and rebuilt with each free housing parameter at ± step (keys
    (name, ±1)), and those names; ({}, []) when a step leaves the valid region."""

    housing_names = [n for n in housing_parameter_names(model.kind) if free is not None and n in free]
    housings = {}
    if housing_names:
        try:
            housings[None] = build_housings(model.kind, values)
            for name in housing_names:
                for sign in (1, -1):
                    shifted = dict(values)
                    shifted[name] += sign * HOUSING_STEP
                    housings[(name, sign)] = build_housings(model.kind, shifted)
        except UsvipsError:  # a step leaves the valid region: the reference path's differences serve
            housings, housing_names = {}, []
    return housings, housing_names


def stereo_derivatives(model, values: dict[str, float], computed: np.ndarray,
                       free: frozenset[str] | None = None) -> Columns:
    """Exact columns of the Jacobian of ``model`` (a :class:`~usvips.core.calibration.model.StereoModel`)
    at ``values`` whose computed pixels are ``computed``: ``{parameter: {block: column}}`` for the
    interior, pose and (those in ``free``; default none) housing parameters of every block (see the module
    docstring); a block whose pixels are not all valid, or whose rays cannot be traced, is left to the
    reference path's differences.

    Each side's pixels of every station are traced in one batch (:func:`_side_batches`: the housing sits in
    the camera frame); under :func:`usvips.core.batch_mode.reference` each block is traced by its own camera
    (:func:`_per_block_derivatives`, the reference path)."""
    if using_reference():
        return _per_block_derivatives(model, values, computed, free)
    return _side_batches(model, values, computed, free)


def _side_batches(model, values: dict[str, float], computed: np.ndarray, free: frozenset[str] | None) -> Columns:
    """:func:`stereo_derivatives` with one trace per side: every block's pixels of that side traced from
    the camera at the origin of its own frame (rays, their pixel derivatives, ideal coordinates), the
    pixel Jacobian rows ∂pixel/∂P_camera turned into the object frame by each block's rotation
    (∂pixel/∂P = ∂pixel/∂P_camera · M); the interior columns of a side at once; the pose columns per block."""
    from usvips.core.camera import Camera

    housings, housing_names = _shifted_housings(model, values, free)
    out: Columns = {}
    try:
        base = housings[None] if housings else build_housings(model.kind, values)
        frames_m, frames_c = model.station_frames(values)
    except UsvipsError:
        return out
    xyz = model.control_xyz(values)
    first = model.stations[0]
    shared_plane = model.housing_kind.right_follows_rig
    following: list[tuple] = []
    rotations: dict = {}
    for side, side_name in enumerate(("l", "r")):
        blocks = [b for b in range(len(model.blocks)) if model.block_side[b] == side
                  and np.all(np.isfinite(computed[model.blocks[b]]))]
        if not blocks:
            continue
        pixels = np.vstack([computed[model.blocks[b]].reshape(-1, 2) for b in blocks])
        counts = [len(model.block_points[b]) for b in blocks]
        ends = np.cumsum([0, *counts])
        points = xyz[np.concatenate([model.block_points[b] for b in blocks])]
        which = np.repeat(model.block_station[blocks], counts)
        rotation = frames_m[which, side]
        local = np.einsum("nij,nj->ni", rotation, points - frames_c[which, side])
        try:
            interior = interior_of(values, side_name)
            camera = Camera(interior, ORIGIN, base[side])
            warm = [model._warm.get(b) for b in blocks]
            warm = np.vstack(warm) if all(w is not None for w in warm) else None
            uv, bundle, d_origin, d_direction, unreached = _side_rays(camera, pixels, local, warm,
                                                                      model.rays_from_points[side])
        except UsvipsError:
            continue
        model.rays_from_points[side] = unreached is not None
        for name, column in interior_columns(interior, uv).items():
            if unreached is not None:
                column.reshape(-1, 2)[unreached] = 0.0
            into = out.setdefault(f"{name}_{side_name}", {})
            for k, b in enumerate(blocks):
                into[b] = column[2 * ends[k]: 2 * ends[k + 1]]
        along = np.einsum("ij,ij->i", local - bundle.origins, bundle.directions)
        a0, a1, valid = pixel_jacobian(bundle.directions, d_origin, d_direction, along)
        a0 = np.einsum("ni,nij->nj", a0, rotation)
        a1 = np.einsum("ni,nij->nj", a1, rotation)
        good = bundle.ok & valid
        if unreached is not None:  # an unreached row's pose and housing columns: zero (see _side_rays)
            a0[unreached] = a1[unreached] = 0.0
            good |= unreached
        due: list[tuple] = []
        vectorised = not (shared_plane and side == 1)
        if vectorised:  # every block's pose columns at once (the shared cover plane's right side: below)
            fine = [k for k, _ in enumerate(blocks) if good[ends[k]: ends[k + 1]].all()]
            _pose_columns_of_side(model, values, side, blocks, fine, ends, which, points - frames_c[which, side],
                                  a0, a1, out)
        for k, b in enumerate(blocks):
            rows = slice(ends[k], ends[k + 1])
            if not good[rows].all():
                continue
            if vectorised:
                if housing_names:
                    due.append((b, frames_m[model.block_station[b], side], uv[rows], a0[rows], a1[rows], along[rows]))
                continue
            station = model.stations[model.block_station[b]]
            m, c, derivatives = pose_derivatives(values, station, side_name, first, rotations)
            entry = (b, m, uv[rows], a0[rows], a1[rows], along[rows])
            if shared_plane and side == 1:
                moving = {n: d for n, d in derivatives.items() if "@" not in n}
                derivatives = {n: d for n, d in derivatives.items() if "@" in n}
                if moving:
                    following.append((entry, pose_columns(m, c, moving, a0[rows], a1[rows], points[rows]), None))
            for name, column in pose_columns(m, c, derivatives, a0[rows], a1[rows], points[rows]).items():
                out.setdefault(name, {})[b] = column
            if housing_names:
                due.append(entry)
        if due:
            for name, columns in side_housing_columns(housings, housing_names, side, due).items():
                out.setdefault(name, {}).update(columns)
    _add_rig_housing_terms(model, values, following, out)
    return out


def _side_rays(camera, pixels: np.ndarray, local: np.ndarray, warm: np.ndarray | None = None,
               from_points: bool = False) -> tuple[np.ndarray, object, np.ndarray, np.ndarray, np.ndarray | None]:
    """The ideal normalised coordinates (N, 2) of a side's computed ``pixels``, their rays with the
    derivatives per pixel (camera frame, the camera at the origin), and the rows whose point no ray reaches
    (None: every row's is reached).

    From the pixels, undistorted, where they all can be. A point the housing cannot image (behind the
    camera, missing a surface: the evaluation marks its observation invalid and the adjustment leaves it
    out) gets whatever pixel its failed solve left, often far beyond the lens distortion's fold, where it
    cannot be undistorted: then the rays come from the points themselves (``local``, camera frame,
    back-projected through the housing as the evaluation does), an unreached row traced along the optical
    axis so that the others keep their exact columns (its own are zeroed by the caller, as forward
    differences give a row that stays invalid on both sides of the step). ``warm``: the side's pixels at
    the model's last evaluation (NaN where invalid), where the back-projection starts as the evaluation's
    does; ``from_points``: go to the points at once (the side needed them at the last Jacobian: the
    undistortion would fail again after all its iterations)."""
    if not from_points:
        try:
            uv = camera.interior.pixels_to_normalised(pixels)
            return (uv, *camera.rays_with_derivatives(pixels), None)
        except UsvipsError:
            pass
    uv, status = camera.ideal_of_points(local, warm)
    unreached = status != RayStatus.OK
    uv[unreached] = 0.0
    return (uv, *camera.rays_with_derivatives_at_ideal(uv), unreached if unreached.any() else None)


def _station_rotations(values: dict[str, float], names: list[str]) -> tuple[np.ndarray, list[np.ndarray]]:
    """M (S, 3, 3) of the cameras whose (omega, phi, kappa) are ``names`` (S entries of three names)
    and ∂M/∂angle for each angle (central differences, as :func:`_rotation_and_derivatives`)."""
    angles = np.array([[values[n] for n in triple] for triple in names])
    derivatives = []
    for k in range(3):
        ahead, behind = angles.copy(), angles.copy()
        ahead[:, k] += POSE_STEP
        behind[:, k] -= POSE_STEP
        derivatives.append((rotation_matrix(*ahead.T) - rotation_matrix(*behind.T)) / (2 * POSE_STEP))
    return rotation_matrix(*angles.T), derivatives


def _pose_columns_of_side(model, values, side: int, blocks: list[int], fine: list[int], ends: np.ndarray,
                          which: np.ndarray, relative: np.ndarray, a0: np.ndarray, a1: np.ndarray,
                          out: Columns) -> None:
    """The pose columns of the ``fine`` blocks (positions in ``blocks``) of one side, all at once: for
    every pose parameter θ that moves a camera, per station G = Mᵀ ∂M/∂θ and ∂C/∂θ (the composition of
    :func:`pose_derivatives`, stacked over stations), and per row ∂pixel/∂θ = a · (G (P − C) − ∂C/∂θ)
    with a the object-frame pixel Jacobian rows ``a0``, ``a1`` (N, 3), ``relative`` = P − C (N, 3) and
    ``which`` (N,) each row's station. Written into ``out`` per block."""
    stations = model.stations
    count = len(stations)
    left_names = [[f"{a}_l" if s == 0 else f"{a}_l@{stations[s]}" for a in ANGLES] for s in range(count)]
    left_centres = np.array([[values[f"{p}_l" if s == 0 else f"{p}_l@{stations[s]}"] for p in ("X0", "Y0", "Z0")]
                             for s in range(count)])
    m_l, d_l = _station_rotations(values, left_names)
    unit = np.eye(3)
    zero_g, zero_c = np.zeros((count, 3, 3)), np.zeros((count, 3))
    # roles: (G (S, 3, 3), dC (S, 3), name of station s or None where the role does not apply)
    roles: list[tuple[np.ndarray, np.ndarray, object]] = []
    own = ["X0", "Y0", "Z0"]
    if side == 0:
        m = m_l
        for k, p in enumerate(own):
            roles.append((zero_g, np.broadcast_to(unit[k], (count, 3)),
                          lambda s, p=p: f"{p}_l" if s == 0 else f"{p}_l@{stations[s]}"))
        for k, a in enumerate(ANGLES):
            roles.append((np.swapaxes(m, 1, 2) @ d_l[k], zero_c,
                          lambda s, a=a: f"{a}_l" if s == 0 else f"{a}_l@{stations[s]}"))
    else:
        m_r0, d_r0 = _station_rotations(values, [[f"{a}_r" for a in ANGLES]])
        m_r0, d_r0 = m_r0[0], [d[0] for d in d_r0]
        m_l0, d_l0 = m_l[0], [d[0] for d in d_l]
        c_l0 = left_centres[0]
        c_r0 = np.array([values[f"{p}_r"] for p in ("X0", "Y0", "Z0")])
        gap = c_r0 - c_l0
        base = m_l0 @ gap
        m_rel = m_r0 @ m_l0.T
        m = m_rel @ m_l                                   # (S, 3, 3); station 0 is m_r0 itself
        m[0] = m_r0
        m_t = np.swapaxes(m, 1, 2)
        carry = np.swapaxes(m_l, 1, 2) @ m_l0             # (S, 3, 3)
        further = lambda name: (lambda s: None if s == 0 else name)  # noqa: E731
        for k, p in enumerate(own):
            roles.append((zero_g, np.broadcast_to(unit[k], (count, 3)),
                          lambda s, p=p: f"{p}_r" if s == 0 else f"{p}_l@{stations[s]}"))
            roles.append((zero_g, -carry[:, :, k], further(f"{p}_l")))
            roles.append((zero_g, carry[:, :, k], further(f"{p}_r")))
        for k, a in enumerate(ANGLES):
            g_own = m_t @ (m_rel @ d_l[k])
            g_own[0] = m_r0.T @ d_r0[k]
            c_own = np.einsum("sji,j->si", d_l[k], base)
            c_own[0] = 0.0
            roles.append((g_own, c_own, lambda s, a=a: f"{a}_r" if s == 0 else f"{a}_l@{stations[s]}"))
            roles.append((m_t @ (m_r0 @ d_l0[k].T @ m_l), np.einsum("sji,j->si", m_l, d_l0[k] @ gap),
                          further(f"{a}_l")))
            roles.append((m_t @ (d_r0[k] @ m_l0.T @ m_l), zero_c, further(f"{a}_r")))
    if not fine:
        return
    for g, d_c, name_of in roles:
        moved = np.einsum("nij,nj->ni", g[which], relative) - d_c[which]
        column = np.empty(2 * len(which))
        column[0::2] = np.einsum("ij,ij->i", a0, moved)
        column[1::2] = np.einsum("ij,ij->i", a1, moved)
        for k in fine:
            b = blocks[k]
            name = name_of(int(model.block_station[b]))
            if name is not None:
                out.setdefault(name, {})[b] = column[2 * ends[k]: 2 * ends[k + 1]]


def _add_rig_housing_terms(model, values, following: list[tuple], out: Columns) -> None:
    """The right camera's first-station pose columns under a shared cover plane: its motion plus its
    housing's (batched per side), for the blocks where both are known."""
    rig_housings, rig_names = _rig_housings(model, values) if following else ({}, [])
    if not rig_names:
        return
    terms = side_housing_columns(rig_housings, rig_names, 1, [entry for entry, _, _ in following])
    _combine_rig_terms(following, terms, out)


def _combine_rig_terms(following: list[tuple], terms: Columns, out: Columns) -> None:
    """Each right block's first-station pose columns under a shared cover plane: the camera's motion plus
    its housing's term; a pose that moves only the housing (the left camera's first pose, for the right
    camera at the first station, which has its own pose) has the housing's term alone."""
    for entry, motion, _ in following:
        b = entry[0]
        for name, column in motion.items():
            if b in terms.get(name, {}):
                out.setdefault(name, {})[b] = column + terms[name][b]
        for name, columns in terms.items():
            if name not in motion and b in columns:
                out.setdefault(name, {})[b] = columns[b]


def _per_block_derivatives(model, values: dict[str, float], computed: np.ndarray,
                           free: frozenset[str] | None = None) -> Columns:
    """:func:`stereo_derivatives` block by block: each block's camera traces its own pixels (the
    reference path)."""
    housings, housing_names = _shifted_housings(model, values, free)
    xyz = model.control_xyz(values)
    out: Columns = {}
    first = model.stations[0]
    shared_plane = model.housing_kind.right_follows_rig  # the right housing moves with the rig (a shared cover)
    following: list[tuple] = []  # right blocks whose first-station pose columns await their housing term
    cameras: dict[str, tuple] = {}
    rotations: dict = {}  # each camera's M and ∂M/∂angle, once per Jacobian
    shared: dict = {}  # the housings and the relative orientation, once for every station
    batched: dict[int, list[tuple]] = {0: [], 1: []}  # per side: the blocks whose housing columns are due
    for b, (station, side) in enumerate(model.block_keys):
        rows = model.blocks[b]
        pixels = computed[rows].reshape(-1, 2)
        if not np.all(np.isfinite(pixels)):
            continue
        try:
            if station not in cameras:
                cameras[station] = model.cameras(values, station, bounded=False, shared=shared)
            camera = cameras[station][0 if side == "l" else 1]
            uv = camera.interior.pixels_to_normalised(pixels)
            bundle, d_origin, d_direction = camera.rays_with_derivatives(pixels)
        except UsvipsError:
            continue
        suffix = f"_{side}"
        for name, column in interior_columns(camera.interior, uv).items():
            out.setdefault(f"{name}{suffix}", {})[b] = column
        if not bundle.ok.all():
            continue
        points = xyz[model._index[model.block_rows[b]]]
        along = np.einsum("ij,ij->i", points - bundle.origins, bundle.directions)
        a0, a1, valid = pixel_jacobian(bundle.directions, d_origin, d_direction, along)
        if not valid.all():
            continue
        m, c, derivatives = pose_derivatives(values, station, side, first, rotations)
        if shared_plane and side == "r":
            # the right housing follows the relative orientation: the first station's poses move it too;
            # their columns get that housing term added below (or are left to the reference path)
            moving = {n: d for n, d in derivatives.items() if "@" not in n}
            derivatives = {n: d for n, d in derivatives.items() if "@" in n}
            if moving:
                following.append(((b, camera, uv, a0, a1, along), pose_columns(m, c, moving, a0, a1, points), pixels))
        for name, column in pose_columns(m, c, derivatives, a0, a1, points).items():
            out.setdefault(name, {})[b] = column
        if housing_names:
            index = 0 if side == "l" else 1
            if using_reference():
                columns = housing_columns(housings, housing_names, index, camera, pixels, a0, a1, along)
                for name, column in columns.items():
                    out.setdefault(name, {})[b] = column
            else:
                batched[index].append((b, camera, uv, a0, a1, along))
    for index, blocks in batched.items():
        if blocks:
            for name, columns in side_housing_columns(housings, housing_names, index, blocks).items():
                out.setdefault(name, {}).update(columns)
    rig_housings, rig_names = _rig_housings(model, values) if following else ({}, [])
    if rig_names:
        if using_reference():  # each block's own traces
            terms: dict[str, dict[int, np.ndarray]] = {}
            for (b, camera, _, a0, a1, along), _, pixels in following:
                for name, column in housing_columns(rig_housings, rig_names, 1, camera, pixels, a0, a1, along).items():
                    terms.setdefault(name, {})[b] = column
        else:
            terms = side_housing_columns(rig_housings, rig_names, 1, [entry for entry, _, _ in following])
        _combine_rig_terms(following, terms, out)
    return out


def _rig_housings(model, values: dict[str, float]) -> tuple[dict, list[str]]:
    """The housings rebuilt with each first-station pose parameter at ± :data:`HOUSING_STEP` (metres,
    radians), for a kind whose right housing follows the rig's relative orientation: keyed like
    :func:`housing_columns`' ``housings``, and the parameter names. ({}, []) when a step leaves the
    valid region (the reference path's differences then serve)."""

    names = [f"{p}_{side}" for side in ("l", "r") for p in ("X0", "Y0", "Z0", *ANGLES)]
    try:
        built = {None: build_housings(model.kind, values)}
        for name in names:
            for sign in (1, -1):
                shifted = dict(values)
                shifted[name] += sign * HOUSING_STEP
                built[(name, sign)] = build_housings(model.kind, shifted)
    except UsvipsError:
        return {}, []
    return built, names


def side_housing_columns(housings: dict, names: list[str], index: int, blocks: list[tuple]
                         ) -> dict[str, dict[int, np.ndarray]]:
    """:func:`housing_columns` of every block of one side (``index`` 0 left, 1 right) at once: ``blocks``
    holds (block, camera or its rotation M (3 × 3), ideal normalised coordinates uv (N, 2), pixel Jacobian
    rows a0, a1 (N, 3), the points' distances along their rays (N,), metres). One trace of all their rays
    (camera frame; compiled where the housing's surfaces compile) per shifted housing, and every block's
    column formed in the same array operations; a block with a ray that fails in a shifted housing gets no
    column (the reference path's differences serve). Returns {parameter: {block: column}}."""
    base = housings[None][index]
    uv = np.vstack([entry[2] for entry in blocks])
    sizes = [len(entry[2]) for entry in blocks]
    ends = np.cumsum([0] + sizes)
    # per row: its block's rotation (vectors turn into the object frame as rows @ M), Jacobian rows, distance
    rotations = np.repeat(np.stack([entry[1] if isinstance(entry[1], np.ndarray) else entry[1].exterior.rotation
                                    for entry in blocks]), sizes, axis=0)
    a0, a1 = np.vstack([entry[3] for entry in blocks]), np.vstack([entry[4] for entry in blocks])
    along = np.concatenate([entry[5] for entry in blocks])[:, None]
    out: dict[str, dict[int, np.ndarray]] = {}
    for name in names:
        ahead, behind = housings[(name, 1)][index], housings[(name, -1)][index]
        if _same(ahead, base) and _same(behind, base):
            continue
        try:
            plus, minus = _camera_frame_rays(ahead, uv), _camera_frame_rays(behind, uv)
        except UsvipsError:
            continue
        fine = (plus[2] == RayStatus.OK) & (minus[2] == RayStatus.OK)
        # the rays' motion in the camera frame, turned into the object frame
        moved = np.einsum("ni,nij->nj", (plus[0] - minus[0]) + along * (plus[1] - minus[1]), rotations)
        moved /= 2 * HOUSING_STEP
        column = np.empty(2 * len(uv))
        column[0::2] = -np.einsum("ni,ni->n", a0, moved)
        column[1::2] = -np.einsum("ni,ni->n", a1, moved)
        failed = np.flatnonzero(~fine)
        spoilt = set(np.searchsorted(ends, failed, side="right").tolist())  # blocks (by position) with a failure
        columns = {entry[0]: column[2 * ends[k]:2 * ends[k + 1]] for k, entry in enumerate(blocks)
                   if k + 1 not in spoilt}
        if columns:
            out[name] = columns
    return out


def _camera_frame_rays(housing, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(origins, directions, status) of the camera-frame rays (u, v, −1) of ``uv`` (N, 2) traced through
    ``housing`` (camera frame)."""
    if kernels.wanted(len(uv), housing.surfaces):
        return kernels.trace_ideal_in_housing(housing, uv)[:3]
    directions = np.column_stack([uv, -np.ones(len(uv))])
    traced = housing.trace(np.zeros_like(directions), directions)
    return traced.origins, traced.directions, traced.status


def housing_columns(housings: dict, names: list[str], index: int, camera, pixels: np.ndarray,
                    a0: np.ndarray, a1: np.ndarray, along: np.ndarray) -> dict[str, np.ndarray]:
    """∂pixel/∂h for the housing parameters ``names`` of ``camera`` (``index`` 0 left, 1 right): its
    ``pixels`` traced through the housings rebuilt at h ± step (``housings`` keyed (name, ±1), the
    unshifted one under None); the rays' motion at distance ``along`` (metres) through the pixel Jacobian
    rows ``a0``, ``a1``. A parameter that does not change this camera's housing gets no column; one whose
    shifted rays fail is left to the reference path."""
    base = housings[None][index]
    out = {}
    for name in names:
        ahead, behind = housings[(name, 1)][index], housings[(name, -1)][index]
        if _same(ahead, base) and _same(behind, base):
            continue
        plus = replace(camera, housing=ahead).rays_with_derivatives(pixels)[0]
        minus = replace(camera, housing=behind).rays_with_derivatives(pixels)[0]
        if not (np.all(plus.status == RayStatus.OK) and np.all(minus.status == RayStatus.OK)):
            continue
        moved = ((plus.origins - minus.origins) + along[:, None] * (plus.directions - minus.directions)) \
            / (2 * HOUSING_STEP)
        column = np.empty(2 * len(pixels))
        column[0::2] = -(a0 * moved).sum(axis=1)
        column[1::2] = -(a1 * moved).sum(axis=1)
        out[name] = column
    return out


def _same(one, other) -> bool:
    try:
        return bool(one == other)
    except (ValueError, TypeError):  # a housing holding arrays does not compare by value
        return False
