"""The window's panels by id, each made the first time it is wanted: its dock shown (the dock starts empty),
or the panel asked for by a command, a controller or a test (``panels[id]``). A survey opened with the
precision planner, the plan view or the QA list behind another tab never pays for them. Free of Qt."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any


class LazyPanels(Mapping):
    """A mapping from each declared panel id to its widget, made by ``make(panel_id)`` on first reading.
    Its keys are every declared id (in their order); :meth:`built` gives only the panels made so far."""

    def __init__(self, ids: Iterable[str], make: Callable[[str], Any]) -> None:
        self._ids = tuple(ids)
        self._make = make
        self._built: dict[str, Any] = {}

    def __getitem__(self, panel_id: str) -> Any:
        if panel_id not in self._built:
            if panel_id not in self._ids:
                raise KeyError(panel_id)
            self._built[panel_id] = self._make(panel_id)
        return self._built[panel_id]

    def __contains__(self, panel_id: object) -> bool:  # declared, made or not (Mapping's would make it)
        return panel_id in self._ids

    def __iter__(self) -> Iterator[str]:
        return iter(self._ids)

    def __len__(self) -> int:
        return len(self._ids)

    def is_built(self, panel_id: str) -> bool:
        """Whether the panel has been made."""
        return panel_id in self._built

    def built(self) -> dict[str, Any]:
        """The panels made so far, by id (a copy)."""
        return dict(self._built)


__all__ = ["LazyPanels"]
