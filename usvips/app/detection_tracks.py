"""Proposals of a video run joined into fish: the proposals just stored on successive looked-at frames that
are the same fish (by their 3-D snout and fork, their σ and a largest fish speed:
:func:`usvips.core.detection.association.associate`) become ONE object — the first sighting — with the later
sightings as its further instants (:func:`usvips.app.object_instants.add_instant`), so the survey counts
the fish once and its length combines its instants (:mod:`usvips.app.project_figures`).

Each instant was detected on its own frame: the links are stored as instants *picked*, not tracked
(``tracked_from`` None). The model's errors on one fish still repeat in part from frame to frame; combining
them keeps that part whole by the model's measured frame correlation, which each vertex's source states
(:func:`usvips.app.project_figures.evaluate`), and keeps the whole error when the model has none. Only
proposals stored by the run and measured (with a length and its σ) are joined; a person's object, an
earlier run's proposal, a duplicate not stored, or a proposal without a length is never touched.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from usvips.app.object_instants import add_instant
from usvips.core.detection.association import DEFAULT_MAX_SPEED_M_S, Association, Sighting, associate
from usvips.core.measurements.evaluate import Measurement
from usvips.store.interface import ProjectStore


@dataclass(frozen=True)
class StoredSighting:
    """A proposal stored by a run: its object id, left frame, time (s) and measurement."""

    object_id: int
    frame: int
    time_s: float
    measurement: Measurement


@dataclass(frozen=True)
class JoinedFish:
    """What joining stored: each fish seen on several frames as (its object id, its further instants' ids),
    how many links were refused as ambiguous, and the largest speed (m/s) the links allowed."""

    fish: tuple[tuple[int, tuple[int, ...]], ...]
    ambiguous: int
    max_speed_m_s: float

    @property
    def instants(self) -> int:
        """How many further instants were linked."""
        return sum(len(rest) for _, rest in self.fish)

    def line(self) -> str:
        """One line for a person: the fish joined, their instants, and the links refused."""
        return (f"{len(self.fish)} fish seen on several frames joined into objects with {self.instants} further "
                f"instant(s) (fish taken to swim at most {self.max_speed_m_s:g} m/s); {self.ambiguous} link(s) "
                "not made: another fish was as near")


def sighting(stored: StoredSighting) -> Sighting:
    """The association's view of a stored proposal: its keypoints' 3-D points and covariance blocks."""
    m = stored.measurement
    blocks = np.array([m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(len(m.points))])
    return Sighting(stored.frame, stored.time_s, m.points, blocks)


def join_sightings(project: ProjectStore, stored: Sequence[StoredSighting], frames: Sequence[int],
                   max_speed_m_s: float = DEFAULT_MAX_SPEED_M_S) -> JoinedFish:
    """Join ``stored`` (proposals of one run on one video, ``frames`` the left frames looked at in order) into
    fish and link each fish's later sightings as further instants of its first (one transaction)."""
    found = fish_of(stored, frames, max_speed_m_s)
    links = fish_links(stored, found)
    link_instants(project, links)
    return JoinedFish(tuple(links), found.ambiguous, float(max_speed_m_s))


def fish_of(stored: Sequence[StoredSighting], frames: Sequence[int],
            max_speed_m_s: float = DEFAULT_MAX_SPEED_M_S) -> Association:
    """Which of ``stored`` are one fish (:func:`usvips.core.detection.association.associate`; nothing stored)."""
    return associate([sighting(s) for s in stored], max_speed_m_s, frames=frames)


def fish_links(stored: Sequence[StoredSighting], found: Association) -> list[tuple[int, tuple[int, ...]]]:
    """Each fish of ``found`` as (its first sighting's object id, its later sightings' ids): the links to store."""
    links = []
    for chain in found.joined:
        whole, *rest = (stored[i].object_id for i in chain)
        links.append((whole, tuple(rest)))
    return links


def link_instants(project: ProjectStore, links: Sequence[tuple[int, Sequence[int]]]) -> None:
    """Store ``links`` — (object id, the ids to make its further instants) — in one transaction (none: nothing)."""
    if not any(rest for _, rest in links):
        return
    with project.transaction():
        for whole, rest in links:
            for instant in rest:
                add_instant(project, whole, instant)
