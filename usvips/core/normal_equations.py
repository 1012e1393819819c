"""The normal equations of the weighted least-squares engine (:mod:`usvips.core.adjustment`), formed with
the structure of a calibration's Jacobian, and the redundancy numbers without an (n × n) matrix.

A calibration's Jacobian J (n observations × k free parameters; pixels per parameter unit) is block
sparse: an observation block (one camera at one station) depends on that camera's interior, its pose
(six parameters, or the eighteen that compose a right camera following the rig at a further station)
and its housing — typically a third of the columns. The normal matrix N = Jᵀ W J (W the diagonal
weights, 1/pixel²) is therefore summed block by block over each block's own columns,
Σ_b J_bᵀ W_b J_b, at a tenth of the dense product's arithmetic. With a few stations N stays small (tens
of unknowns) and dense. A calibration from hundreds of board views has one pose per view: those
"local" unknowns each touch one station's two blocks, and N takes the block-arrow form
[[U, W], [Wᵀ, V]] with V block diagonal. :class:`BlockJacobian` stores J by block (never n × k),
:class:`Partition` finds the local groups in its pattern, :class:`ArrowSystem` forms U, V, W batched
over classes of like blocks and eliminates V by the Schur complement S = U − W V⁻¹ Wᵀ, and
:class:`Inverse` holds N⁻¹ in block form (never the blocks between two stations): time and memory
linear in the number of views.

Redundancy numbers need the leverages h_i = a_i Q aᵀ_i of every observation row a_i (Q = N⁻¹): the
diagonal of the hat matrix J Q Jᵀ, here ``((J @ Q) * J).sum(1)`` in one matrix product, never the
(n × n) matrix itself.

The straightforward dense computation (``Jᵀ (W J)`` and the hat matrix's diagonal by ``einsum``) stays
as the reference path: under :func:`usvips.core.batch_mode.reference` every call here takes it, so tests
can compare the two on the same problem (they agree to rounding).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from usvips.core.batch_mode import using_reference


class Pattern:
    """Where a Jacobian (n × k) can be non-zero: observation blocks (row index arrays) and, per block, the
    columns that may be non-zero in its rows. Every entry outside these (block, columns) pairs is zero."""

    def __init__(self, blocks: Sequence[np.ndarray], columns: Sequence[np.ndarray], width: int) -> None:
        self.blocks = [as_rows(b) for b in blocks]
        self.columns = [np.asarray(c, dtype=int) for c in columns]
        self.width = int(width)


def as_rows(rows: np.ndarray) -> slice | np.ndarray:
    """A slice for a contiguous ascending run of row indices (a view, no copy), else the index array."""
    if isinstance(rows, slice):
        return rows
    rows = np.asarray(rows, dtype=int)
    if rows.size and rows[-1] - rows[0] == rows.size - 1 and np.all(np.diff(rows) == 1):
        return slice(int(rows[0]), int(rows[-1]) + 1)
    return rows


def weighted_gram(jac: np.ndarray, weights: np.ndarray, pattern: Pattern | None = None) -> np.ndarray:
    """Jᵀ W J (k × k) of ``jac`` (n × k) with the diagonal weights ``weights`` (n,): summed block by block
    over each block's own columns when the Jacobian's ``pattern`` is given (rows outside every block
    must be zero), else (or under :func:`usvips.core.batch_mode.reference`) the dense product."""
    if pattern is None or using_reference():
        return jac.T @ (jac * weights[:, None])
    normal = np.zeros((jac.shape[1], jac.shape[1]))
    for rows, columns in zip(pattern.blocks, pattern.columns, strict=True):
        if not columns.size:
            continue
        part = jac[rows][:, columns]
        weighted = part * weights[rows][:, None]
        normal[np.ix_(columns, columns)] += part.T @ weighted
    return normal


def leverage(jac: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The hat matrix's diagonal a_i Q a_iᵀ (n,) of the rows a_i of ``jac`` (n × k) with ``q`` (k × k)
    symmetric, in units of 1 / weight (pixels² for q = N⁻¹): one product, no (n × n) matrix."""
    if using_reference():
        return np.einsum("ij,jk,ik->i", jac, q, jac)
    return ((jac @ q) * jac).sum(axis=1)


# ---------------------------------------------------------------------------------------------------
# block-sparse Jacobian and the block-arrow (Schur complement) normal equations
# ---------------------------------------------------------------------------------------------------

class BlockJacobian:
    """A Jacobian (n × k, observation units per parameter unit) stored by observation block: for block b
    its rows ``blocks[b]`` (slice or index array), its columns ``columns[b]`` (ascending free-parameter
    indices) and the dense (rows × columns) sub-matrix ``values[b]``; every other entry is zero. Memory
    and every product below are linear in the number of blocks: the (n × k) matrix is formed only on
    request (:meth:`dense`, for small problems and tests)."""

    def __init__(self, n: int, width: int, blocks: Sequence, columns: Sequence[np.ndarray],
                 values: Sequence[np.ndarray]) -> None:
        self.n, self.width = int(n), int(width)
        self.blocks = list(blocks)
        self.columns = [np.asarray(c, dtype=int) for c in columns]
        self.values = list(values)

    @property
    def pattern(self) -> Pattern:
        return Pattern(self.blocks, self.columns, self.width)

    def dense(self) -> np.ndarray:
        """The (n × k) matrix."""
        out = np.zeros((self.n, self.width))
        for rows, columns, values in zip(self.blocks, self.columns, self.values, strict=True):
            if columns.size:
                out[_grid(rows, columns)] = values
        return out

    def transpose_times(self, vector: np.ndarray) -> np.ndarray:
        """Jᵀ v (k,) of v (n,)."""
        out = np.zeros(self.width)
        for rows, columns, values in zip(self.blocks, self.columns, self.values, strict=True):
            if columns.size:
                out[columns] += values.T @ vector[rows]
        return out

    def gram(self, weights: np.ndarray) -> np.ndarray:
        """Jᵀ W J (k × k), summed block by block over each block's own columns."""
        normal = np.zeros((self.width, self.width))
        for rows, columns, values in zip(self.blocks, self.columns, self.values, strict=True):
            if columns.size:
                normal[np.ix_(columns, columns)] += values.T @ (values * weights[rows][:, None])
        return normal

    def leverage(self, q: np.ndarray) -> np.ndarray:
        """a_i Q a_iᵀ (n,) of every row a_i with ``q`` (k × k) symmetric (see :func:`leverage`)."""
        out = np.zeros(self.n)
        for rows, columns, values in zip(self.blocks, self.columns, self.values, strict=True):
            if columns.size:
                out[rows] = ((values @ q[np.ix_(columns, columns)]) * values).sum(axis=1)
        return out


def _grid(rows, columns: np.ndarray):
    if isinstance(rows, slice):
        return rows, columns
    return np.ix_(rows, columns)


class Partition:
    """The free parameters split into global ones and local groups for the Schur complement.

    A local group is a set of parameters that touch the same few observation blocks, which no other
    group touches (a further station's pose: its left and right block). ``glob`` (g,) holds the global
    parameters' free indices; ``local`` (s, m) each group's free indices, padded with −1 to the largest
    group's size m; ``position[j]`` is parameter j's place among the globals or its slot in its group,
    ``group_of[j]`` its group (−1 for a global one); ``block_group[b]`` the group whose parameters block
    b touches (−1: none)."""

    def __init__(self, width: int, groups: Sequence[Sequence[int]], block_group: np.ndarray) -> None:
        self.width = int(width)
        size = max((len(g) for g in groups), default=0)
        self.local = np.full((len(groups), size), -1, dtype=int)
        self.group_of = np.full(width, -1, dtype=int)
        self.position = np.zeros(width, dtype=int)
        for s, group in enumerate(groups):
            self.local[s, : len(group)] = group
            self.group_of[list(group)] = s
            self.position[list(group)] = np.arange(len(group))
        self.glob = np.flatnonzero(self.group_of < 0)
        self.position[self.glob] = np.arange(self.glob.size)
        self.mask = self.local >= 0
        self.block_group = np.asarray(block_group, dtype=int)

    @classmethod
    def of(cls, pattern: Pattern, eligible: np.ndarray, max_blocks: int, max_size: int = 12
           ) -> Partition | None:
        """The partition a Jacobian's ``pattern`` allows: the ``eligible`` (k,) parameters (e.g. not in a
        correlated prior group) are grouped by the set of blocks they appear in; a group is local when
        that set has at most ``max_blocks`` blocks shared with no other group, and at most ``max_size``
        members. None when no group is local."""
        touched: list[list[int]] = [[] for _ in range(pattern.width)]
        for b, columns in enumerate(pattern.columns):
            for j in columns:
                touched[j].append(b)
        by_set: dict[tuple[int, ...], list[int]] = {}
        for j in range(pattern.width):
            if eligible[j] and 0 < len(touched[j]) <= max_blocks:
                by_set.setdefault(tuple(touched[j]), []).append(j)
        owner: dict[int, tuple[int, ...]] = {}
        clash: set[tuple[int, ...]] = set()
        for key in by_set:
            for b in key:
                if b in owner:
                    clash.update((key, owner[b]))
                else:
                    owner[b] = key
        keys = [key for key, group in by_set.items() if key not in clash and len(group) <= max_size]
        if not keys:
            return None
        block_group = np.full(len(pattern.columns), -1, dtype=int)
        for s, key in enumerate(keys):
            block_group[list(key)] = s
        return cls(pattern.width, [by_set[key] for key in keys], block_group)

    def split(self, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(global part (g,), local part (s, m), zero in the padding) of a free-parameter vector (k,)."""
        local = np.where(self.mask, vector[np.maximum(self.local, 0)], 0.0)
        return vector[self.glob], local

    def join(self, glob: np.ndarray, local: np.ndarray) -> np.ndarray:
        """The free-parameter vector (k,) of a global (g,) and a local (s, m) part."""
        out = np.zeros(self.width)
        out[self.glob] = glob
        out[self.local[self.mask]] = local[self.mask]
        return out


class BlockClass:
    """Observation blocks of one shape, stacked for batched products: the same number of rows, the same
    global columns and the same local slots (e.g. every further station's left block of a full board).
    ``blocks`` (B,) their numbers, ``rows`` (B, r) their observation indices, ``values`` (B, r, c) their
    Jacobian entries, ``is_global`` (c,) which of the c columns are global, ``gi`` their places among the
    globals, ``slots`` the local columns' slots, ``groups`` (B,) each block's local group (−1: none)."""

    def __init__(self, blocks, rows, values, is_global, gi, slots, groups) -> None:
        self.blocks, self.rows, self.values = blocks, rows, values
        self.is_global, self.gi, self.slots, self.groups = is_global, gi, slots, groups
        #: no two blocks of the class in one group: scattered sums need no accumulation of duplicates
        self.distinct = bool(np.unique(groups).size == groups.size)


def _scatter_add(target: np.ndarray, index: tuple, values: np.ndarray, distinct: bool) -> None:
    """target[index] += values, accumulating repeated indices (np.add.at) only where they can occur."""
    if distinct:
        target[index] += values
    else:
        np.add.at(target, index, values)


def block_classes(jac: BlockJacobian, partition: Partition) -> list[BlockClass]:
    """The blocks of ``jac`` grouped into :class:`BlockClass` es under ``partition`` (blocks without
    columns left out). Raises ValueError when a block touches another group's local unknowns."""
    p = partition
    keys: dict[tuple, list[int]] = {}
    for b, columns in enumerate(jac.columns):
        if not columns.size:
            continue
        is_global = p.group_of[columns] < 0
        local = columns[~is_global]
        group = p.block_group[b]
        if local.size and (group < 0 or np.any(p.group_of[local] != group)):
            raise ValueError("a block touches local unknowns of a group it does not belong to")
        key = (len(jac.values[b]), tuple(is_global), tuple(p.position[columns[is_global]]),
               tuple(p.position[local]))
        keys.setdefault(key, []).append(b)
    out = []
    for (_, is_global, gi, slots), blocks in keys.items():
        rows = np.stack([np.arange(r.start, r.stop) if isinstance(r, slice) else np.asarray(r) for r in
                         (jac.blocks[b] for b in blocks)])
        values = np.stack([jac.values[b] for b in blocks])
        out.append(BlockClass(np.array(blocks), rows, values, np.array(is_global, dtype=bool),
                              np.array(gi, dtype=int), np.array(slots, dtype=int), p.block_group[blocks]))
    return out


class ArrowSystem:
    """Normal equations N = [[U, W], [Wᵀ, V]] in block-arrow form: U (g × g) over the global unknowns,
    V (s, m, m) block diagonal over the local groups, W (s, g, m) their coupling, right-hand sides bg (g,)
    and bl (s, m). The observations' share (JᵀWJ, JᵀWv) and the priors' share are kept apart, so that the
    priors can be reweighted (variance components): :meth:`matrices` gives U, V with the priors times a
    factor. Single priors may sit on any unknown, correlated prior groups on global ones only.

    Solves eliminate the local unknowns (Schur complement S = U − Σ W V⁻¹ Wᵀ, g × g) with every local block
    inverted at once (a batched 6 × 6 inverse per station): the cost is linear in the number of groups.
    Everything is done on the equilibrated system (unit diagonal, as the dense path)."""

    def __init__(self, jac: BlockJacobian, weights: np.ndarray, residual: np.ndarray, partition: Partition
                 ) -> None:
        self.partition = p = partition
        g, (s, m) = p.glob.size, p.local.shape
        u, v, w = np.zeros((g, g)), np.zeros((s, m, m)), np.zeros((s, g, m))
        bg, bl = np.zeros(g), np.zeros((s, m))
        weighted = weights * residual
        cached = getattr(jac, "classes_cache", None)  # one grouping per Jacobian and partition
        if cached is None or cached[0] is not partition:
            jac.classes_cache = (partition, block_classes(jac, partition))
        self.classes = jac.classes_cache[1]
        for cls in self.classes:  # each class's products batched over its blocks
            weight = weights[cls.rows][:, :, None]                      # (B, r, 1)
            wr = weighted[cls.rows]                                     # (B, r)
            a = cls.values[:, :, cls.is_global]                         # (B, r, cg)
            gi = cls.gi
            if gi.size:
                flat = a.reshape(-1, gi.size)
                u[np.ix_(gi, gi)] += flat.T @ (flat * weight.reshape(-1, 1))
                bg[gi] += flat.T @ wr.reshape(-1)
            if not cls.slots.size:
                continue
            bb = cls.values[:, :, ~cls.is_global]                       # (B, r, cl)
            bw = bb * weight
            groups, slots = cls.groups, cls.slots
            _scatter_add(v, (groups[:, None, None], slots[None, :, None], slots[None, None, :]),
                         np.swapaxes(bb, 1, 2) @ bw, cls.distinct)
            if gi.size:
                _scatter_add(w, (groups[:, None, None], gi[None, :, None], slots[None, None, :]),
                             np.swapaxes(a, 1, 2) @ bw, cls.distinct)
            _scatter_add(bl, (groups[:, None], slots[None, :]), np.einsum("brl,br->bl", bb, wr), cls.distinct)
        self.u_obs, self.v_obs, self.w, self.bg_obs, self.bl_obs = u, v, w, bg, bl
        self.prior_diagonal = np.zeros(p.width)
        self.prior_rhs = np.zeros(p.width)
        self.prior_groups: list[tuple[np.ndarray, np.ndarray]] = []

    def add_priors(self, diagonal: np.ndarray, rhs: np.ndarray,
                   groups: Sequence[tuple[np.ndarray, np.ndarray]]) -> None:
        """Prior pseudo-observations: weights on the diagonal (k,), their right-hand side (k,), and
        correlated groups (free indices, weight matrix) on global unknowns."""
        self.prior_diagonal = self.prior_diagonal + diagonal
        self.prior_rhs = self.prior_rhs + rhs
        for index, weight in groups:
            if np.any(self.partition.group_of[index] >= 0):
                raise ValueError("a correlated prior group on local unknowns")
            self.prior_groups.append((self.partition.position[index], weight))

    @property
    def has_priors(self) -> bool:
        return bool(np.any(self.prior_diagonal) or self.prior_groups)

    def matrices(self, factor: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """U and V with the priors' weights times ``factor``; V's padding has a unit diagonal."""
        p = self.partition
        u = self.u_obs.copy()
        pg, pl = p.split(self.prior_diagonal)
        u[np.diag_indices_from(u)] += factor * pg
        for index, weight in self.prior_groups:
            u[np.ix_(index, index)] += factor * weight
        v = self.v_obs.copy()
        diagonal = np.einsum("sii->si", v)
        diagonal += factor * pl
        diagonal[~p.mask] = 1.0
        return u, v

    def rhs(self) -> tuple[np.ndarray, np.ndarray]:
        pg, pl = self.partition.split(self.prior_rhs)
        return self.bg_obs + pg, self.bl_obs + pl

    def scale(self) -> np.ndarray:
        """The equilibration (k,): the square root of the full normal matrix's diagonal."""
        u, v = self.matrices()
        return np.sqrt(np.maximum(self.partition.join(np.diag(u), np.einsum("sii->si", v)), 1e-300))

    def reduced(self, damping: float = 0.0, factor: float = 1.0):
        """The equilibrated system's pieces: (scale (k,), S (g × g) the Schur complement, V⁻¹ (s, m, m),
        Y = W V⁻¹ (s, g, m), the scaled W (s, g, m)), all with ``damping`` added to the unit diagonal and
        the priors times ``factor``. Raises numpy's LinAlgError when a local block is singular."""
        p = self.partition
        u, v = self.matrices(factor)
        scale = np.sqrt(np.maximum(p.join(np.diag(u), np.einsum("sii->si", v)), 1e-300))
        sg, sl = p.split(scale)
        sl = np.where(p.mask, sl, 1.0)
        us = u / np.outer(sg, sg)
        vs = v / (sl[:, :, None] * sl[:, None, :])
        ws = self.w / (sg[None, :, None] * sl[:, None, :])
        if damping:
            us[np.diag_indices_from(us)] += damping
            np.einsum("sii->si", vs)[...] += damping
        v_inverse = np.linalg.inv(vs)
        y = ws @ v_inverse
        schur = us - np.tensordot(y, ws, axes=([0, 2], [0, 2]))
        return scale, (schur + schur.T) / 2, v_inverse, y, ws

    def step(self, damping: float) -> np.ndarray:
        """The damped step (k,): (N̄ + damping·I) x̄ = b̄ on the equilibrated system, x = x̄ / scale."""
        scale, schur, v_inverse, y, ws = self.reduced(damping)
        bg, bl = self.rhs()
        sg, sl = self.partition.split(scale)
        rg, rl = bg / sg, np.where(self.partition.mask, bl / np.where(self.partition.mask, sl, 1.0), 0.0)
        xg = np.linalg.solve(schur, rg - np.einsum("sgm,sm->g", y, rl))
        xl = np.einsum("smn,sn->sm", v_inverse, rl - np.einsum("sgm,g->sm", ws, xg))
        return self.partition.join(xg, xl) / scale

    def inverse(self, factor: float = 1.0, reduced=None) -> Inverse:
        """N⁻¹ (with the priors times ``factor``) in its block form (:class:`Inverse`)."""
        scale, schur, v_inverse, y, _ = reduced if reduced is not None else self.reduced(0.0, factor)
        q_scaled = np.linalg.inv(schur)
        q_scaled = (q_scaled + q_scaled.T) / 2
        sg, sl = self.partition.split(scale)
        sl = np.where(self.partition.mask, sl, 1.0)
        qy = q_scaled @ y                                               # (s, g, m)
        qgg = q_scaled / np.outer(sg, sg)
        qgl = -qy / (sg[None, :, None] * sl[:, None, :])
        qll = (v_inverse + np.swapaxes(y, 1, 2) @ qy) / (sl[:, :, None] * sl[:, None, :])
        return Inverse(self.partition, qgg, qgl, (qll + np.swapaxes(qll, 1, 2)) / 2)

    def trace_with_observations(self, inverse: Inverse) -> float:
        """tr(Q N_obs): Q = ``inverse`` against the observations' share of the normal matrix."""
        return float(np.sum(inverse.qgg * self.u_obs) + 2.0 * np.sum(inverse.qgl * self.w)
                     + np.sum(inverse.qll * self.v_obs))


class Inverse:
    """N⁻¹ in block form: ``qgg`` (g × g) over the globals, ``qgl`` (s, g, m) between the globals and each
    group's locals, ``qll`` (s, m, m) within each group (entries of the padding are meaningless). The
    blocks between two different groups are never formed (they would be quadratic in the groups)."""

    def __init__(self, partition: Partition, qgg: np.ndarray, qgl: np.ndarray, qll: np.ndarray) -> None:
        self.partition, self.qgg, self.qgl, self.qll = partition, qgg, qgl, qll

    def diagonal(self) -> np.ndarray:
        """diag(Q) (k,)."""
        return self.partition.join(np.diag(self.qgg), np.einsum("sii->si", self.qll))

    def leverage(self, jac: BlockJacobian, classes: Sequence[BlockClass] | None = None) -> np.ndarray:
        """a_i Q a_iᵀ (n,) of every row of ``jac``: per block, Q restricted to the block's own columns,
        batched over each class of like blocks (``classes``: :func:`block_classes`, formed if not given)."""
        out = np.zeros(jac.n)
        for cls in classes if classes is not None else block_classes(jac, self.partition):
            ig, il = np.flatnonzero(cls.is_global), np.flatnonzero(~cls.is_global)
            gi, slots, groups = cls.gi, cls.slots, cls.groups
            c = cls.is_global.size
            q = np.empty((len(cls.blocks), c, c))
            q[:, ig[:, None], ig[None, :]] = self.qgg[np.ix_(gi, gi)]
            if il.size:
                cross = self.qgl[groups[:, None, None], gi[None, :, None], slots[None, None, :]]  # (B, cg, cl)
                q[:, ig[:, None], il[None, :]] = cross
                q[:, il[:, None], ig[None, :]] = np.swapaxes(cross, 1, 2)
                q[:, il[:, None], il[None, :]] = self.qll[groups[:, None, None], slots[None, :, None],
                                                          slots[None, None, :]]
            out[cls.rows] = ((cls.values @ q) * cls.values).sum(axis=2)
        return out

    def correlations_over(self, names: Sequence[str], limit: float) -> list[tuple[str, str, float]]:
        """Pairs (name, name, ρ) with |ρ| > ``limit``: among the globals, within each group and between a
        group and the globals (never between two groups: those blocks are not formed). Vectorised."""
        p = self.partition
        sigma = np.sqrt(np.maximum(self.diagonal(), 1e-300))
        sg, sl = p.split(sigma)
        sl = np.where(p.mask, sl, 1.0)
        out = []
        corr = self.qgg / np.outer(sg, sg)
        i, j = np.nonzero(np.triu(np.abs(corr) > limit, 1))
        out += [(names[p.glob[a]], names[p.glob[b]], float(corr[a, b])) for a, b in zip(i, j, strict=True)]
        corr = self.qll / (sl[:, :, None] * sl[:, None, :])
        s, i, j = np.nonzero(np.triu(np.ones(corr.shape[1:], bool), 1)[None] & (np.abs(corr) > limit)
                             & p.mask[:, :, None] & p.mask[:, None, :])
        out += [(names[p.local[a, b]], names[p.local[a, c]], float(corr[a, b, c]))
                for a, b, c in zip(s, i, j, strict=True)]
        corr = self.qgl / (sg[None, :, None] * sl[:, None, :])
        s, i, j = np.nonzero((np.abs(corr) > limit) & p.mask[:, None, :])
        out += [(names[p.glob[b]], names[p.local[a, c]], float(corr[a, b, c])) for a, b, c in zip(s, i, j, strict=True)]
        return out
