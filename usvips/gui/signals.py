"""A tiny observer: the Qt-free models announce changes through these, the widgets listen.

Kept free of Qt on purpose (napari's habit): a model and its tools are tested with plain calls, no
window, and a widget connects its ``_on_x_changed`` slots in ``__init__`` and disconnects in ``cleanup``.
"""

from __future__ import annotations

from collections.abc import Callable


class Signal:
    """``connect(slot)``, ``disconnect(slot)``, ``emit(*args)``: slots are called in connection order."""

    def __init__(self) -> None:
        self._slots: list[Callable[..., object]] = []

    def connect(self, slot: Callable[..., object]) -> None:
        if slot not in self._slots:
            self._slots.append(slot)

    def disconnect(self, slot: Callable[..., object]) -> None:
        if slot in self._slots:
            self._slots.remove(slot)

    def emit(self, *args: object) -> None:
        for slot in list(self._slots):
            slot(*args)

    def __len__(self) -> int:
        return len(self._slots)
