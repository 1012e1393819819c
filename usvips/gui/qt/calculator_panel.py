"""The geo-calculator panel: the selected objects' figures with sigmas and the quality rules."""

from __future__ import annotations

from PySide6 import QtWidgets

from usvips.app.quality import object_facts
from usvips.core.measurements.breakdown import breakdown_text
from usvips.gui.calculator import format_figure
from usvips.gui.panel_registry import Panel, register
from usvips.gui.workspace import Workspace


class CalculatorPanel(QtWidgets.QWidget):
    """The geo-calculator on the selected objects, with sigmas and the quality rules (editable)."""

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.selection: list[int] = []
        self.output = QtWidgets.QPlainTextEdit()
        self.output.setReadOnly(True)
        rules = workspace.rules
        self.max_rms = self._spin(rules.max_ray_rms_m * 1000, 0.1, 1000, " mm", "largest ray-intersection RMS")
        self.max_precision = self._spin(rules.max_relative_precision * 100, 0.1, 100, " %",
                                        "largest sigma relative to the length or area")
        self.max_range = self._spin(rules.max_range_m, 0.1, 1000, " m", "largest range from the left camera")
        form = QtWidgets.QGridLayout()  # two rows, so that the rules fit the dock on a 1366 px screen
        for k, (label, spin) in enumerate((("ray RMS ≤", self.max_rms), ("σ/value ≤", self.max_precision),
                                           ("range ≤", self.max_range))):
            form.addWidget(QtWidgets.QLabel(label), k // 2, 2 * (k % 2))
            form.addWidget(spin, k // 2, 2 * (k % 2) + 1)
        form.setColumnStretch(4, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(form)
        layout.addWidget(self.output)
        self._events = ((workspace.selection_changed, self.set_selection), (workspace.objects_reset, self.refresh),
                        (workspace.objects_updated, self._on_objects), (workspace.objects_removed, self._on_objects),
                        (workspace.rules_changed, self.refresh))
        for signal, slot in self._events:
            signal.connect(slot)

    def _spin(self, value: float, low: float, high: float, suffix: str, tip: str) -> QtWidgets.QDoubleSpinBox:
        spin = QtWidgets.QDoubleSpinBox()
        spin.setRange(low, high)
        spin.setDecimals(1)
        spin.setValue(value)
        spin.setSuffix(suffix)
        spin.setToolTip(tip)
        spin.valueChanged.connect(self._on_rules_changed)
        return spin

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)

    def _on_rules_changed(self) -> None:
        from dataclasses import replace

        self.workspace.set_rules(replace(self.workspace.rules, max_ray_rms_m=self.max_rms.value() / 1000,
                                         max_relative_precision=self.max_precision.value() / 100,
                                         max_range_m=self.max_range.value()))

    def set_selection(self, object_ids) -> None:
        self.selection = list(object_ids)
        self.refresh()

    def _on_objects(self, ids: tuple[int, ...]) -> None:
        """Only a change of a shown object is redrawn."""
        if set(ids) & set(self.selection):
            self.refresh()

    def _instant_lines(self) -> list[str]:
        """One object selected that belongs to several instants: which figures these are (survey, issue 25)."""
        if len(self.selection) != 1:
            return []
        object_id, links = self.selection[0], self.workspace.cache.instant_links()
        if object_id in links:
            return [f"one instant of object {links[object_id]}: its figures alone, not the object's (object "
                    f"{links[object_id]}'s are combined over its instants)"]
        count = 1 + sum(1 for whole in links.values() if whole == object_id)
        return [f"combined over {count} instants (I lists them)"] if count > 1 else []

    def refresh(self, *_: object) -> None:
        existing = set(self.workspace.cache.ids())
        self.selection = [i for i in self.selection if i in existing]
        if not self.selection:
            self.output.setPlainText("Select one object for its figures, or two for the figures between them "
                                     "(distance, point–line, point–plane, angle).")
            return
        result = self.workspace.figures(self.selection)
        head = "objects " + " and ".join(str(i) for i in self.selection)
        lines = [head, *self._instant_lines(), ""] + [format_figure(f) for f in result.figures]
        facts = []
        if result.measurement is not None and result.figures:  # one object: its sigma's breakdown and facts
            lines += ["", "sigma " + breakdown_text(result.measurement)]
            if len(self.selection) == 1 and self.selection[0] in self.workspace.cache:
                object_id = self.selection[0]  # the one verdict (app.quality.judge), as the QA panel's
                facts = object_facts(self.workspace.stored_object(object_id), result.measurement, self.workspace.rules,
                                     self.workspace.cache.record(object_id), self.workspace.species_maxima())
        if result.reason:
            lines.append(result.reason)
        if result.figures and not result.reason:
            lines.append("")
            broken = facts if len(self.selection) == 1 and result.measurement is not None else list(result.failures)
            lines.append("quality: " + ("; ".join(broken) if broken else "passes the rules"))
        if any(f.name in ("bearing", "slope") for f in result.figures):
            lines.append(f"bearing (clockwise from +Y towards +X) and slope (above the X–Y plane) are in "
                         f"{self.workspace.frame_description(self.selection[0])}")
        self.output.setPlainText("\n".join(lines))


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("calculator", "Geo-calculator", "right", lambda context: CalculatorPanel(context.workspace),
                     group="figures", order=20))
