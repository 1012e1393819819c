"""Plain data of control points and stereo observations (what the CSV files hold).

Control: ids, object coordinates X, Y, Z (N, 3) in metres and optional a-priori sigmas (N, 3).
Stereo observations: ids, left and right pixel coordinates (N, 2) each (x right, y down, origin at
the centre of the top-left pixel), the stereo pair (station) label of each row, and any extra numeric
columns a file carried (for example the seeds' published differences dX, dY, dZ).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usvips.core.errors import DegenerateGeometryError, InvalidParameterError


@dataclass(frozen=True)
class ControlPoints:
    ids: tuple[str, ...]
    xyz: np.ndarray
    sigmas: np.ndarray | None = None
    source: str = ""
    lines: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        xyz = np.asarray(self.xyz, dtype=np.float64).reshape(-1, 3)
        if len(xyz) != len(self.ids):
            raise InvalidParameterError("control", f"{len(self.ids)} ids but {len(xyz)} coordinate rows")
        if len(set(self.ids)) != len(self.ids):
            duplicate = next(i for i in self.ids if self.ids.count(i) > 1)
            raise InvalidParameterError("control", f"duplicate control point id {duplicate!r}")
        object.__setattr__(self, "xyz", xyz)

    def __len__(self) -> int:
        return len(self.ids)

    def index_of(self, ids: tuple[str, ...] | list[str], what: str = "observation") -> np.ndarray:
        """Row indices of ``ids``; raises naming the first id that is not a control point."""
        lookup = {pid: i for i, pid in enumerate(self.ids)}
        missing = [pid for pid in ids if pid not in lookup]
        if missing:
            where = f" in {self.source}" if self.source else ""
            raise DegenerateGeometryError(
                f"{what} id {missing[0]!r} has no control point{where}"
                + (f" ({len(missing)} ids missing: {', '.join(missing[:8])})" if len(missing) > 1 else ""))
        return np.array([lookup[pid] for pid in ids], dtype=np.intp)

    def subset(self, ids) -> ControlPoints:
        idx = self.index_of(list(ids))
        sig = None if self.sigmas is None else self.sigmas[idx]
        lines = tuple(self.lines[i] for i in idx) if self.lines else ()
        return ControlPoints(tuple(self.ids[i] for i in idx), self.xyz[idx], sig, self.source, lines)


@dataclass(frozen=True)
class StereoObservations:
    ids: tuple[str, ...]
    left: np.ndarray
    right: np.ndarray
    pairs: tuple[str, ...] = ()
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = ""
    lines: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        n = len(self.ids)
        left = np.asarray(self.left, dtype=np.float64).reshape(-1, 2)
        right = np.asarray(self.right, dtype=np.float64).reshape(-1, 2)
        if len(left) != n or len(right) != n:
            raise InvalidParameterError("observations", "ids, left and right pixels differ in length")
        pairs = tuple(self.pairs) if self.pairs else ("1",) * n
        if len(pairs) != n:
            raise InvalidParameterError("observations", "one pair label per row is needed")
        object.__setattr__(self, "left", left)
        object.__setattr__(self, "right", right)
        object.__setattr__(self, "pairs", pairs)
        if len(set(zip(pairs, self.ids, strict=True) if len(set(pairs)) > 1 else self.ids)) == n:
            return  # one set built in C: fast for large chunks (of the ids alone in one pair: no tuples)
        seen: set[tuple[str, str]] = set()
        for pid, pair in zip(self.ids, pairs, strict=True):
            if (pair, pid) in seen:
                raise InvalidParameterError("observations", f"id {pid!r} appears twice in pair {pair!r}")
            seen.add((pair, pid))

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def pair_labels(self) -> tuple[str, ...]:
        """Pair labels in order of first appearance (station 0 is the first)."""
        return tuple(dict.fromkeys(self.pairs))

    def pair(self, label: str) -> StereoObservations:
        """The rows of one stereo pair."""
        mask = [p == label for p in self.pairs]
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            raise InvalidParameterError("pair", f"no observations for pair {label!r}; "
                                        f"pairs: {', '.join(self.pair_labels)}")
        return self.take(idx)

    def take(self, idx: np.ndarray) -> StereoObservations:
        idx = np.asarray(idx, dtype=np.intp)
        return StereoObservations(
            tuple(self.ids[i] for i in idx), self.left[idx], self.right[idx],
            tuple(self.pairs[i] for i in idx), {k: v[idx] for k, v in self.extra.items()},
            self.source, tuple(self.lines[i] for i in idx) if self.lines else ())

    def without(self, ids) -> StereoObservations:
        """All rows except those whose id is in ``ids``."""
        drop = set(ids)
        return self.take(np.array([i for i, pid in enumerate(self.ids) if pid not in drop], dtype=np.intp))
