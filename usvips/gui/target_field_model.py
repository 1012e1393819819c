"""The *Find a target field* tool's model, free of Qt: the targets the user identifies in each image of a
pair, the search for the rest (:mod:`usvips.app.target_field`), the doubtful ones accepted, rejected or
placed by hand, and the confirmation that stores them as the pair's control observations.

Interaction: a click in an image waits for its id (:meth:`FieldModel.click`, then :meth:`name`); with
a doubtful target selected, a click in its image places it there instead (accepting it). Pixels: x
right, y down, origin at the centre of the top-left pixel.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from usvips.app import target_field as service
from usvips.core.errors import UsvipsError
from usvips.core.observations import ControlPoints
from usvips.gui.signals import Signal
from usvips.store.interface import ProjectStore

SIDES = service.SIDES
#: how each mark is drawn (the view's colours): a click not yet searched, a found target, a doubtful one,
#: a doubtful one accepted or placed by hand
STATES = ("clicked", "found", "doubtful", "accepted")


class FieldModel:
    """One pair's target field. Events: ``changed()`` after any change of clicks, result or decisions."""

    def __init__(self, project: ProjectStore, pair: str, calibration_id: int | None = None,
                 shape: str = "disc", control: ControlPoints | None = None) -> None:
        """``control``: the field's control when the project holds none (stored with the targets)."""
        self.project = project
        self.job = service.prepare(project, pair, control, calibration_id, shape)
        self.clicks: dict[str, dict[str, tuple[float, float]]] = {side: {} for side in SIDES}
        self.pending: tuple[str, tuple[float, float]] | None = None
        self.selected: tuple[str, str] | None = None
        self.result: service.FieldResult | None = None
        self.accepted: set[tuple[str, str]] = set()
        self.moved: dict[tuple[str, str], tuple[float, float]] = {}
        self.changed = Signal()

    # ------------------------------------------------------------------ what is known
    @property
    def pair(self) -> str:
        return self.job.pair

    def ids(self) -> tuple[str, ...]:
        return self.job.control.ids

    def needed(self) -> int:
        return self.job.needed()

    def more_needed(self, side: str) -> int:
        return max(0, self.needed() - len(self.clicks[side]))

    def count_line(self) -> str:
        """How many targets are identified in each image and how many more are needed."""
        parts = []
        for side in SIDES:
            more = self.more_needed(side)
            tail = f" ({more} more needed)" if more else " (enough)"
            parts.append(f"{side}: {len(self.clicks[side])} identified{tail}")
        return "; ".join(parts)

    def ready(self) -> bool:
        return all(self.more_needed(side) == 0 for side in SIDES)

    def set_calibration(self, calibration_id: int | None) -> None:
        """Search with an earlier calibration's cameras (None: a DLT in air); the result is dropped."""
        self.job.cameras = service.cameras_of(self.project, calibration_id, self.pair)
        self.job.calibration_id = calibration_id
        self._drop_result()

    # ------------------------------------------------------------------ identifying
    def click(self, side: str, pixel: tuple[float, float]) -> str:
        """A click in ``side``'s image: places the selected doubtful target of that image there, else waits
        for an id (:meth:`name`). Returns what happened, in words."""
        pixel = (float(pixel[0]), float(pixel[1]))
        if self.selected is not None and self.selected[0] == side and self.status(*self.selected) == "doubtful":
            return self.move(side, self.selected[1], pixel)
        self.pending = (side, pixel)
        self.changed.emit()
        return f"{side} image clicked at ({pixel[0]:.1f}, {pixel[1]:.1f}): which target is it?"

    def move(self, side: str, pid: str, pixel: tuple[float, float]) -> str:
        """Place a doubtful target at ``pixel`` (dragged or clicked there): it is accepted there."""
        if self.status(side, pid) != "doubtful":
            raise UsvipsError(f"{side} {pid} is not doubtful: only a doubtful target is placed by hand")
        pixel = (float(pixel[0]), float(pixel[1]))
        if not service.inside(pixel, self.job.size(side)):
            raise UsvipsError(f"{side} {pid}: ({pixel[0]:.1f}, {pixel[1]:.1f}) is outside the image")
        self.moved[(side, pid)] = pixel
        self.selected = (side, pid)
        self.changed.emit()
        return f"{side} {pid} placed at ({pixel[0]:.1f}, {pixel[1]:.1f}) and accepted"

    def name(self, pid: str) -> None:
        """Name the click waiting for its id; an id not in the control is an error naming it."""
        if self.pending is None:
            raise UsvipsError("click a target in an image first, then name it")
        pid = pid.strip()
        if pid not in self.ids():
            raise UsvipsError(f"{pid!r} is not a target of the field's control")
        side, pixel = self.pending
        self.clicks[side][pid] = pixel
        self.pending = None
        self.selected = (side, pid)
        self._drop_result()

    def remove(self, side: str, pid: str) -> None:
        """Forget a click."""
        if self.clicks[side].pop(pid, None) is not None:
            self._drop_result()

    def _drop_result(self) -> None:
        self.result = None
        self.accepted.clear()
        self.moved.clear()
        self.changed.emit()

    # ------------------------------------------------------------------ searching
    def search_job(self) -> Callable[[Callable[[float], None], Callable[[], bool]], object]:
        """The search as a plain function of copies (``job(progress, cancelled)``, for the worker)."""
        self.job.check(self.clicks)
        clicks = {side: dict(self.clicks[side]) for side in SIDES}
        job = self.job
        return lambda progress, cancelled: job.run(clicks, progress, cancelled)

    def set_result(self, result: service.FieldResult | None) -> None:
        self.result = result
        self.accepted.clear()
        self.moved.clear()
        self.changed.emit()

    # ------------------------------------------------------------------ the result
    def status(self, side: str, pid: str) -> str:
        """found | doubtful | missing after a search; clicked or "" before."""
        if self.result is None:
            return "clicked" if pid in self.clicks[side] else ""
        return self.result.side(side).target(pid).status

    def decision(self, side: str, pid: str) -> str:
        """A doubtful target's fate: "placed", "accepted" or "" (left out)."""
        key = (side, pid)
        return "placed" if key in self.moved else "accepted" if key in self.accepted else ""

    def marks(self, side: str) -> list[tuple[str, tuple[float, float], str]]:
        """(id, pixel, state) of each target to draw in ``side``'s image (:data:`STATES`)."""
        if self.result is None:
            return [(pid, pixel, "clicked") for pid, pixel in self.clicks[side].items()]
        out = []
        for target in self.result.side(side).targets:
            key = (side, target.id)
            if key in self.moved:
                out.append((target.id, self.moved[key], "accepted"))
            elif target.pixel is not None and target.status != "missing":
                state = "accepted" if key in self.accepted else target.status
                out.append((target.id, target.pixel, state))
        return out

    def predictions(self, side: str) -> list[tuple[str, tuple[float, float]]]:
        """(id, pixel) where the model puts each doubtful target of ``side``'s image (to compare with where
        it was located or clicked)."""
        if self.result is None:
            return []
        return [(t.id, t.predicted) for t in self.result.side(side).targets
                if t.status == "doubtful" and t.predicted is not None and (side, t.id) not in self.moved]

    def rows(self) -> list[tuple[str, str, str, str]]:
        """(side, id, status, words) of every target worth listing: the clicks before a search; after it
        the doubtful (with the decision), then the missing, then the found."""
        if self.result is None:
            return [(side, pid, "clicked", f"({x:.1f}, {y:.1f})") for side in SIDES
                    for pid, (x, y) in self.clicks[side].items()]
        rows = []
        for status in ("doubtful", "missing", "found"):
            for side in SIDES:
                for target in self.result.side(side).targets:
                    if target.status != status:
                        continue
                    words = target.reason
                    decision = self.decision(side, target.id) if status == "doubtful" else ""
                    if decision:
                        words = f"{decision}; {words}"
                    elif status == "found":
                        words = "clicked" if target.clicked else "found"
                    rows.append((side, target.id, status, words))
        return rows

    def summary(self) -> str:
        if self.result is None:
            return self.count_line()
        lines = [f"{side}: {self.result.side(side).summary()}" for side in SIDES]
        if self.job.caution():
            lines.append(f"Note: {self.job.caution()} (choose it above).")
        lines += [self.result.side(side).advice() for side in SIDES if self.result.side(side).advice()]
        usable = len(self.result.observations(self.accepted, self.moved))
        lines.append(f"{usable} target{'s' * (usable != 1)} usable in both images will be stored on Confirm")
        return "\n".join(lines)

    def accept(self, side: str, pid: str) -> None:
        """Keep a doubtful target where it was located (one without a pixel must be placed by a click)."""
        if self.status(side, pid) != "doubtful":
            raise UsvipsError(f"{side} {pid} is not doubtful: only a doubtful target is accepted or rejected")
        if self.result.side(side).target(pid).pixel is None and (side, pid) not in self.moved:
            raise UsvipsError(f"{side} {pid} was not located: click where it is to place it")
        self.accepted.add((side, pid))
        self.changed.emit()

    def reject(self, side: str, pid: str) -> None:
        """Leave a doubtful target out (undoes an accept or a placing)."""
        if self.status(side, pid) != "doubtful":
            raise UsvipsError(f"{side} {pid} is not doubtful: only a doubtful target is accepted or rejected")
        self.accepted.discard((side, pid))
        self.moved.pop((side, pid), None)
        self.changed.emit()

    def confirm(self) -> service.Confirmed:
        """Store the found, accepted and placed targets seen in both images (see :func:`service.confirm`);
        the stored set as read becomes the new one, so that a second confirmation is checked against it."""
        if self.result is None:
            raise UsvipsError("find the rest of the field first")
        confirmed = service.confirm(self.project, self.result, self.accepted, self.moved)
        stored = self.project.control_observations(self.result.role, self.pair)
        self.result = dataclasses.replace(self.result, stored=stored, stored_control=self.project.control())
        self.changed.emit()
        return confirmed
