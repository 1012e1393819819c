"""MaxN per species from reviewed objects: on each video (or image pair), the largest number of ACCEPTED
objects of one species (their attribute) measured on one left frame, and the first frame where it is
reached. Each accepted object is one individual on its frame (an object over several instants is one
object per frame, so a fish is never counted twice on one frame); objects without a species, unreviewed
or flagged ones (proposals not yet checked among them) are not counted. The count itself is
:func:`usvips.core.abundance.max_n`."""

from __future__ import annotations

from dataclasses import dataclass

from usvips.core.abundance import max_n
from usvips.store.interface import ProjectStore


@dataclass(frozen=True)
class SpeciesMaxN:
    """``where`` (a video or pair label), ``species``, ``max_n`` individuals on ``frame`` (the first left
    frame reaching it; None on an image pair) and ``objects``: the accepted objects of the species there."""

    where: str
    species: str
    max_n: int
    frame: int | None
    objects: int

    def line(self) -> str:
        at = f" at frame {self.frame}" if self.frame is not None else ""
        return f"{self.where} {self.species}: MaxN {self.max_n}{at} (from {self.objects} accepted objects)"


def reviewed_max_n(project: ProjectStore) -> list[SpeciesMaxN]:
    """MaxN of each species on each video or pair of ``project`` from its accepted objects (see the module
    docstring), by place then species."""
    accepted = sorted(r.object_id for r in project.reviews("accepted"))
    groups, frames = [], []
    for stored in project.objects_with_ids(accepted):
        species = stored.attribute.strip()
        if not species or not stored.vertices or stored.vertices[0].pair is None:
            continue
        first = stored.vertices[0]
        groups.append((first.pair, species))
        frames.append(first.frame_left if first.video is not None else None)
    counts = max_n(groups, frames, [1] * len(groups))
    out = []
    for (where, species), best in sorted(counts.items()):
        mine = [f for g, f in zip(groups, frames, strict=True) if g == (where, species)]
        frame = min((f for f in set(mine) if mine.count(f) == best), key=lambda f: -1 if f is None else f)
        out.append(SpeciesMaxN(where, species, best, frame, len(mine)))
    return out
