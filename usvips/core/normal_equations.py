"""The normal equations of the weighted least-squares engine (:mod:`usvips.core.adjustment`), formed with
the structure of a calibration's Jacobian, and the redundancy numbers without an (n × n) matrix.

A calibration's Jacobian J (n observations × k free parameters; pixels per parameter unit) is block
sparse: an observation block (one camera at one station) depends on that camera's interior, its pose
(six parameters, or the eighteen that compose a right camera following the rig at a further station)
and its housing — typically a third of the columns. The normal matrix N = Jᵀ W J (W the diagonal
weights, 1/pixel²) is therefore summed block by block over each block's own columns,
Σ_b J_bᵀ W_b J_b, at a tenth of the dense product's arithmetic. Object points are no unknowns of the
survey-size case (the control is known), so cameras and housing are all there is and N stays small
(tens to a few hundred unknowns) and dense: its solves and inverses are not where the time goes.

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
