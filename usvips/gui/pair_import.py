"""Adding a dive's image pairs in the window, free of Qt: the pairing found in two folders, each pair's
label (a prefix for all, or edited one by one), size and status, which pairs are ticked, and the medium.

A second dive's folder with the same camera names (GoPro's ``GOPR0042`` in every dive) clashes with the
labels already in the project: a prefix (``dive2-``) or an edited label resolves it, and the status says
so. A pair that cannot be added (left and right of different sizes, an unreadable file, a label used
twice) is named and left out; the good ones are added (:meth:`PairImport.add`). Sizes are (width, height)
in pixels as the files' headers declare them (nothing is decoded until the pairs are added).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from usvips.app import video_project
from usvips.core.errors import UsvipsError
from usvips.gui.signals import Signal
from usvips.gui.wording import plural
from usvips.io.images import declared_size
from usvips.store.interface import ProjectStore

MEDIA = ("water", "air")
OK = "ok"


def header_size(path: Path) -> tuple[int, int] | None:
    """(width, height) px an image file's header declares, None when unreadable or not told."""
    try:
        with open(path, "rb") as file:
            return declared_size(file.read(1 << 16))
    except OSError:
        return None


@dataclass
class PairRow:
    """One planned pair: the label the pairing gave it (without prefix), the label typed over it (empty:
    none), its files, their sizes (px), and whether the user ticks it."""

    base: str
    left: Path
    right: Path
    left_size: tuple[int, int] | None
    right_size: tuple[int, int] | None
    edited: str = ""
    ticked: bool = True


class PairImport:
    """The pairs about to be added to ``project``, as the Add image pairs dialog shows and edits them.

    Event: ``changed()`` after any edit (labels, ticks, prefix, medium): a view redraws every row.
    """

    def __init__(self, project: ProjectStore, plan: list[tuple[str, Path, Path]], rule: str, prefix: str = "",
                 medium: str = "water") -> None:
        self.project = project
        self.rule = rule
        self.rows = [PairRow(label, Path(left), Path(right), header_size(Path(left)), header_size(Path(right)))
                     for label, left, right in plan]
        self.prefix = prefix
        self.medium = medium
        self._taken = {p.label for p in project.pairs()}
        self.changed = Signal()

    # ------------------------------------------------------------------ edits
    def set_prefix(self, prefix: str) -> None:
        """Put ``prefix`` before every label not typed over."""
        self.prefix = prefix.strip()
        self.changed.emit()

    def set_label(self, row: int, text: str) -> None:
        """Type over one pair's label (empty: back to the prefix and the label found)."""
        text = text.strip()
        self.rows[row].edited = "" if text == self.prefix + self.rows[row].base else text
        self.changed.emit()

    def set_ticked(self, row: int, ticked: bool) -> None:
        self.rows[row].ticked = bool(ticked)
        self.changed.emit()

    def set_medium(self, medium: str) -> None:
        if medium not in MEDIA:
            raise UsvipsError(f"medium must be one of {', '.join(MEDIA)}, got {medium!r}")
        self.medium = medium
        self.changed.emit()

    # ------------------------------------------------------------------ what is shown
    def label(self, row: int) -> str:
        found = self.rows[row]
        return found.edited or f"{self.prefix}{found.base}"

    def size_text(self, row: int) -> str:
        found = self.rows[row]
        if found.left_size is None or found.right_size is None:
            return "?"
        if found.left_size == found.right_size:
            return f"{found.left_size[0]} × {found.left_size[1]}"
        return f"{found.left_size[0]} × {found.left_size[1]} | {found.right_size[0]} × {found.right_size[1]}"

    def status(self, row: int) -> str:
        """``ok`` or every reason that keeps the pair out (ticked or not), joined by "; ": the files' own
        faults first (they need other files), then the label's (a prefix or another label mends them)."""
        found = self.rows[row]
        label = self.label(row)
        problems = []
        if found.left.resolve() == found.right.resolve():
            problems.append("one file on both sides")
        unreadable = [side for side, size in (("left", found.left_size), ("right", found.right_size)) if size is None]
        if unreadable:
            problems.append(f"the {unreadable[0]} image is not a readable image")
        elif found.left_size != found.right_size:
            problems.append(f"left {found.left_size[0]} × {found.left_size[1]} px, right "
                            f"{found.right_size[0]} × {found.right_size[1]} px")
        if not label or "/" in label or "\\" in label or label.startswith("."):
            problems.append("needs a label without slashes that does not start with '.'")
        elif label in self._taken:
            problems.append("label already in the project: give a prefix or another label")
        elif found.ticked and sum(self.label(i) == label for i, r in enumerate(self.rows) if r.ticked) > 1:
            problems.append("label given twice")
        return "; ".join(problems) or OK

    def good(self) -> list[int]:
        """Rows ticked and fit to add."""
        return [i for i, r in enumerate(self.rows) if r.ticked and self.status(i) == OK]

    def bad(self) -> list[str]:
        """One line per ticked row that cannot be added: its label and why."""
        return [f"{self.label(i)}: {self.status(i)}" for i, r in enumerate(self.rows)
                if r.ticked and self.status(i) != OK]

    def summary(self) -> str:
        """``2 pairs to add (water), 1 left out: …`` for the dialog's line above its buttons."""
        ticked = sum(r.ticked for r in self.rows)
        text = f"{plural(len(self.good()), 'pair')} to add ({self.medium}), paired by {self.rule}"
        if ticked < len(self.rows):
            text += f"; {len(self.rows) - ticked} unticked"
        bad = self.bad()
        if bad:
            text += f"; {len(bad)} cannot be added (see Status)"
        return text

    # ------------------------------------------------------------------ adding
    def add(self) -> tuple[list[str], list[str]]:
        """Add the good pairs (one transaction) with the medium chosen; returns the labels added and one
        line per ticked pair left out (its label and why). A pair refused only when its pixels are read
        (a damaged file whose header looked fine) is named too, and the rest still added."""
        rows = self.good()
        left_out = self.bad()
        plan = [(self.label(i), self.rows[i].left, self.rows[i].right) for i in rows]
        while plan:
            try:
                video_project.add_image_pairs(self.project, plan, self.medium)
                break
            except UsvipsError as error:
                culprit = next((p for p in plan if any(str(f) in str(error) or f.name in str(error) for f in p[1:])
                                or repr(p[0]) in str(error)), None)
                if culprit is None:
                    raise
                plan.remove(culprit)
                left_out.append(f"{culprit[0]}: {error}")
        self._taken |= {label for label, _, _ in plan}
        self.changed.emit()
        return [label for label, _, _ in plan], left_out
