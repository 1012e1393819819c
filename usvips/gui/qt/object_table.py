"""The object list's table model: one row per stored object, read from the workspace's object cache when
a row is drawn (nothing is copied per row, so a survey of 100,000 objects opens and scrolls at once).

Rows are object ids: every id the cache holds, in id order, or sorted by a column (:meth:`sort`) and
filtered by a text (:meth:`set_filter`). The cells' texts are made from the cache on demand and kept per
object until it changes; an object whose figures are not known under the current rules shows
"computing…" and is asked for through ``wanted`` (the view computes the figures of the rows it draws).
"""

from __future__ import annotations

import bisect
from collections import Counter
from collections.abc import Callable, Iterable

import numpy as np
from PySide6 import QtCore, QtGui

from usvips.app.quality import object_facts
from usvips.core.measurements.breakdown import breakdown_text
from usvips.gui.calculator import format_figure
from usvips.gui.qt.live_updates import TINT
from usvips.gui.video_model import video_frame_text
from usvips.gui.wording import species_text

_Role = QtCore.Qt.ItemDataRole

#: what a figure cell says while its figures are being computed
COMPUTING = "computing…"
#: the quality cell of an object without figures (why is in its figure cell)
NO_FIGURE = "no figures"  # the QA rule's words (usvips.app.quality)
_TEXT = {int(_Role.DisplayRole), int(_Role.EditRole)}
_FOREGROUND, _TOOLTIP, _BACKGROUND = int(_Role.ForegroundRole), int(_Role.ToolTipRole), int(_Role.BackgroundRole)
_ROLES = frozenset({*_TEXT, _FOREGROUND, _TOOLTIP, _BACKGROUND, int(_Role.UserRole)})
_FLAGS = QtCore.Qt.ItemFlag.ItemIsEnabled | QtCore.Qt.ItemFlag.ItemIsSelectable
_EDITABLE_FLAGS = _FLAGS | QtCore.Qt.ItemFlag.ItemIsEditable


def review_text(review) -> str:
    """A review in the list: ``unreviewed`` (the default), ``accepted``, ``flagged: reason``."""
    if review is None:
        return "unreviewed"
    return review.state + (f": {review.reason}" if review.reason else "")


def instant_figure(object_id: int, main: str, figured: bool, links: dict[int, int], instants: Counter
                   ) -> tuple[str, str]:
    """The figure cell's text and tooltip (Qt-free): an object over several instants says how many (its
    figure is the combined one); a further instant names its object, its own figure only in the tooltip."""
    whole = links.get(object_id)
    if whole is not None:
        return (f"instant of #{whole}",
                f"one instant of object {whole}; this instant alone: {main}. The object's figure is row "
                f"#{whole}'s, combined over its instants.")
    count = instants.get(object_id, 0) + 1
    if count > 1 and figured:
        return f"{main} ({count} instants)", f"combined over {count} instants (I lists them)"
    return main, ""


def figure_texts(result, object_id: int, links: dict[int, int], instants: Counter) -> tuple[str, str, str]:
    """(figure cell, quality cell, figure tooltip) of an object from its figures ``result`` (None: not
    known yet). The one place the object list's figure texts and tooltip are made."""
    if result is None:
        main, quality = COMPUTING, ""
    elif result.figures:
        main, quality = format_figure(result.figures[0]), "; ".join(result.failures) or "ok"
    else:  # no figure, so no verdict on it: "ok" would pass an object nothing was measured of
        main, quality = result.reason.removeprefix(f"object {object_id}: "), NO_FIGURE
    main, tip = instant_figure(object_id, main, result is not None and bool(result.figures), links, instants)
    if result is not None and result.measurement is not None:  # the sigma's breakdown (one Qt-free text)
        tip = "\n".join(filter(None, [tip, "sigma " + breakdown_text(result.measurement)]))
    return main, quality, tip


def figure_order(values: list[float], ids: list[int], descending: bool = False) -> list[int]:
    """``ids`` by their main figure's ``values``, equal values by id, both in the order asked; a NaN value
    after every other in either order. 20,000 objects in ~2 ms, where sorting (value, id) tuples took ~30 ms
    of the window's thread."""
    figure, held, sign = np.asarray(values, dtype=np.float64), np.asarray(ids, dtype=np.int64), -1 if descending else 1
    return held[np.lexsort((sign * held, sign * figure, np.isnan(figure)))].tolist()


class ObjectTableModel(QtCore.QAbstractTableModel):
    """The stored objects of ``workspace``'s cache as rows of ``columns``; ``editable`` columns are edited
    in place through ``edit(object_id, column, text)``; ``grey`` is the brush of a further instant's row."""

    #: ids whose figures a drawn row needs (not known under the current rules)
    wanted = QtCore.Signal()

    def __init__(self, workspace, columns: tuple[str, ...], editable: tuple[str, ...], grey: QtGui.QBrush,
                 edit: Callable[[int, str, str], None], parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.columns, self.editable, self.grey, self._edit = columns, editable, grey, edit
        self._figure, self._quality = columns.index("figure"), columns.index("quality")
        self._ids: list[int] = []  # the rows' object ids
        self._row: dict[int, int] | None = {}  # object id -> row (None: to be made again)
        self._texts: dict[int, tuple[str, ...]] = {}  # object id -> its cells' texts (kept until it changes)
        self._tips: dict[int, str] = {}
        self.reviews: dict[int, object] = {}
        self.species: dict = {}
        self.links: dict[int, int] = {}
        self.instants: Counter = Counter()
        self.requested: set[int] = set()  # ids asked for through ``wanted`` and not yet known
        self.sort_column, self.sort_order = -1, QtCore.Qt.SortOrder.AscendingOrder
        self.filter_text = ""

    # ------------------------------------------------------------------ rows
    def rowCount(self, parent: QtCore.QModelIndex = QtCore.QModelIndex()) -> int:  # noqa: B008 (Qt's signature)
        return 0 if parent.isValid() else len(self._ids)

    def columnCount(self, parent: QtCore.QModelIndex = QtCore.QModelIndex()) -> int:  # noqa: B008
        return 0 if parent.isValid() else len(self.columns)

    def object_id(self, row: int) -> int:
        return self._ids[row]

    def ids(self) -> list[int]:
        """The ids of the rows, in row order."""
        return list(self._ids)

    def row_of(self, object_id: int) -> int | None:
        if self._row is None:
            self._row = dict(zip(self._ids, range(len(self._ids)), strict=True))
        return self._row.get(object_id)

    def _arranged(self, ids: Iterable[int]) -> list[int]:
        """``ids`` filtered by the filter text and in the sort order."""
        chosen = [i for i in ids if self._matches(i)] if self.filter_text else list(ids)
        if self.sort_column < 0:
            return sorted(chosen)
        column = self.columns[self.sort_column]
        descending = self.sort_order == QtCore.Qt.SortOrder.DescendingOrder
        if column == "figure":  # objects without a figure (not computed, or none) last in either order
            values, valued, rest = self.workspace.cache.main_figures(chosen)
            return figure_order(values, valued, descending) + rest
        return sorted(chosen, key=self._sort_key(column), reverse=descending)

    def reset(self, links: dict[int, int], reviews: dict[int, object]) -> None:
        """Every row again from the cache (another project, everything read again)."""
        self.beginResetModel()
        self.links, self.instants, self.reviews = links, Counter(links.values()), reviews
        self.species = self.workspace.species_maxima()  # for the species rule of the one verdict
        self._texts, self._tips, self.requested = {}, {}, set()
        self._ids, self._row = self._arranged(self.workspace.cache.ids()), None
        self.endResetModel()

    def _plain(self) -> bool:
        return self.sort_column < 0 and not self.filter_text

    def add(self, ids: Iterable[int]) -> None:
        """New objects (in the cache already): their rows inserted where they belong."""
        ids = [i for i in ids if i in self.workspace.cache and self.row_of(i) is None]
        if not ids:
            return
        if not self._plain():
            self.rearrange()
            return
        for object_id in sorted(ids):
            row = bisect.bisect_left(self._ids, object_id)
            self.beginInsertRows(QtCore.QModelIndex(), row, row)
            self._ids.insert(row, object_id)
            if row == len(self._ids) - 1 and self._row is not None:
                self._row[object_id] = row  # a new last row (a fish just stored): no other row moved
            else:
                self._row = None
            self.endInsertRows()

    def remove(self, ids: Iterable[int]) -> None:
        """Objects gone from the cache: their rows removed."""
        for object_id in ids:
            self._texts.pop(object_id, None)
            self._tips.pop(object_id, None)
            self.requested.discard(object_id)
            row = self.row_of(object_id)
            if row is None:
                continue
            self.beginRemoveRows(QtCore.QModelIndex(), row, row)
            del self._ids[row]
            self._row = None
            self.endRemoveRows()

    def changed(self, ids: Iterable[int]) -> None:
        """Objects (or their figures, reviews, instant links) changed: their rows drawn again."""
        for object_id in ids:
            self._texts.pop(object_id, None)
            self._tips.pop(object_id, None)
            row = self.row_of(object_id)
            if row is not None:
                self.dataChanged.emit(self.index(row, 0), self.index(row, len(self.columns) - 1))

    def forget_figures(self) -> None:
        """Every figure may have changed (new rules): every row's figure cells are made again when drawn."""
        self._texts, self._tips, self.requested = {}, {}, set()
        if self._ids:
            self.dataChanged.emit(self.index(0, self._figure), self.index(len(self._ids) - 1, self._quality))

    def set_links(self, links: dict[int, int]) -> set[int]:
        """The project's instant links; returns the ids whose part in them changed (their rows redrawn)."""
        if links == self.links:
            return set()
        touched = {i for link in set(links.items()) ^ set(self.links.items()) for i in link}
        self.links, self.instants = links, Counter(links.values())
        self.changed(sorted(touched))
        return touched

    # ------------------------------------------------------------------ sorting and filtering
    def sort(self, column: int, order: QtCore.Qt.SortOrder = QtCore.Qt.SortOrder.AscendingOrder) -> None:
        """Rows in the order of ``column`` (-1: by id, as stored)."""
        self.sort_column, self.sort_order = column, order
        self.rearrange()

    def set_filter(self, text: str) -> None:
        """Only the rows with ``text`` (any case) in one of their cells."""
        self.filter_text = text.strip().casefold()
        self.rearrange()

    def rearrange(self) -> None:
        """The rows filtered and sorted again (the selection and current row kept on their objects)."""
        self.layoutAboutToBeChanged.emit()
        before = list(self.persistentIndexList())
        ids_before = [self._ids[i.row()] if 0 <= i.row() < len(self._ids) else None for i in before]
        self._ids, self._row = self._arranged(self.workspace.cache.ids()), None
        after = []
        for index, object_id in zip(before, ids_before, strict=True):
            row = self.row_of(object_id) if object_id is not None else None
            after.append(self.index(row, index.column()) if row is not None else QtCore.QModelIndex())
        self.changePersistentIndexList(before, after)
        self.layoutChanged.emit()

    def _matches(self, object_id: int) -> bool:
        return any(self.filter_text in text.casefold() for text in self.texts(object_id, request=False))

    def _sort_key(self, column: str) -> Callable[[int], object]:
        if column == "id":
            return lambda object_id: object_id
        if column == "vertices":
            return lambda object_id: (len(self.workspace.cache.get(object_id).vertices), object_id)
        position = self.columns.index(column)
        return lambda object_id: (self.texts(object_id, request=False)[position].casefold(), object_id)

    # ------------------------------------------------------------------ cells
    def texts(self, object_id: int, request: bool = True) -> tuple[str, ...]:
        """The cells of an object's row (kept until the object, its figures or its review change); figures
        not known are asked for through ``wanted`` when ``request`` (a row drawn, not one sorted)."""
        known = self._texts.get(object_id)
        if known is not None:
            return known
        ws = self.workspace
        stored = ws.cache.get(object_id)
        result = ws.cache.known_figures(object_id)
        main, quality, tip = figure_texts(result, object_id, self.links, self.instants)
        if result is not None and result.measurement is not None:  # the one verdict (app.quality.judge)
            facts = object_facts(stored, result.measurement, ws.rules, ws.cache.record(object_id), self.species)
            broken = list(dict.fromkeys([*result.failures, *facts]))
            quality = "; ".join(broken) or "ok"
        values = {"id": str(object_id), "type": stored.kind, "species": species_text(ws.cache.record(object_id)),
                  "attribute": stored.attribute, "vertices": str(len(stored.vertices)), "figure": main,
                  "quality": quality, "review": review_text(self.reviews.get(object_id)), "notes": stored.notes,
                  "pair": ", ".join(dict.fromkeys(v.pair for v in stored.vertices if v.pair)),
                  "frame": video_frame_text(stored)}
        texts = tuple(values[c] for c in self.columns)
        if result is None:
            if request and object_id not in self.requested:
                self.requested.add(object_id)
                self.wanted.emit()
            return texts  # not kept: shown again once the figures are known
        self._texts[object_id], self._tips[object_id] = texts, tip
        return texts

    def tooltip(self, object_id: int) -> str:
        """The figure cell's tooltip (see :func:`figure_texts`)."""
        if object_id not in self._tips:
            result = self.workspace.cache.known_figures(object_id)
            return figure_texts(result, object_id, self.links, self.instants)[2]
        return self._tips[object_id]

    def data(self, index: QtCore.QModelIndex, role: int = _Role.DisplayRole):
        role = int(role)
        if role not in _ROLES or not index.isValid():  # the roles a drawn cell asks for most hold nothing here
            return None
        row = index.row()
        if not 0 <= row < len(self._ids):
            return None
        object_id = self._ids[row]
        if role in _TEXT:
            return self.texts(object_id)[index.column()] if object_id in self.workspace.cache else None
        if role == _FOREGROUND:
            return self.grey if object_id in self.links else None
        mark = self.workspace.cache.marks.get(object_id)  # a colleague's change (usvips.gui.qt.live_updates)
        if role == _BACKGROUND:
            return TINT if mark is not None else None
        if role == _TOOLTIP:
            tip = (self.tooltip(object_id) or "") if index.column() == self._figure else ""
            return "\n".join(filter(None, [mark.text() if mark is not None else "", tip])) or None
        return object_id  # UserRole

    def flags(self, index: QtCore.QModelIndex) -> QtCore.Qt.ItemFlag:
        if not index.isValid():
            return _FLAGS
        return _EDITABLE_FLAGS if self.columns[index.column()] in self.editable else _FLAGS

    def setData(self, index: QtCore.QModelIndex, value, role: int = _Role.EditRole) -> bool:
        if role != _Role.EditRole or not index.isValid() or self.columns[index.column()] not in self.editable:
            return False
        object_id = self._ids[index.row()]
        if str(value) == self.texts(object_id)[index.column()]:
            return False
        self._edit(object_id, self.columns[index.column()], str(value))
        return True

    def headerData(self, section: int, orientation: QtCore.Qt.Orientation, role: int = _Role.DisplayRole):
        if role == _Role.DisplayRole and orientation == QtCore.Qt.Orientation.Horizontal:
            return self.columns[section].capitalize()
        return None
