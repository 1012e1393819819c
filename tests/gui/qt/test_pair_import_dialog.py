"""File › Add image pairs…'s dialog drives its model: the medium, the prefix, a label typed in the table
and an unticked row reach the model; the Add button counts the good pairs; statuses and sizes are shown."""

import numpy as np
from PySide6 import QtCore, QtWidgets

from usvips.gui.pair_import import PairImport
from usvips.gui.qt.pair_import_dialog import COLUMNS, PairImportDialog
from usvips.io.images import write_image
from usvips.store import Project


def test_the_dialog_edits_the_model_and_shows_sizes_and_statuses(qtbot, tmp_path):
    plan = []
    for k, (left, right) in enumerate([((64, 48), (64, 48)), ((64, 48), (60, 48)), ((64, 48), (64, 48))]):
        paths = []
        for side, size in (("L", left), ("R", right)):
            path = tmp_path / f"GOPR{k}_{side}.png"
            write_image(path, np.zeros((size[1], size[0]), np.uint8))
            paths.append(path)
        plan.append((f"gopr{k}", *paths))
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_pair("gopr0")  # from the first dive
        model = PairImport(project, plan, "shared stem")
        dialog = PairImportDialog(model)
        qtbot.addWidget(dialog)
        status, size = COLUMNS.index("Status"), COLUMNS.index("Size (px)")
        ok = dialog.buttons.button(QtWidgets.QDialogButtonBox.StandardButton.Ok)
        assert dialog.table.item(0, status).text().startswith("label already in the project")
        assert dialog.table.item(1, size).text() == "64 × 48 | 60 × 48"
        assert ok.text() == "&Add 1 pair" and "2 cannot be added" in dialog.summary.text()
        dialog.prefix.setText("dive2-")
        dialog.prefix.textEdited.emit("dive2-")
        assert dialog.table.item(0, 1).text() == "dive2-gopr0" and dialog.table.item(0, status).text() == "ok"
        dialog.table.item(2, 1).setText("big fish")  # typed over in the table
        assert model.label(2) == "big fish"
        dialog.table.item(1, 0).setCheckState(QtCore.Qt.CheckState.Unchecked)
        assert model.rows[1].ticked is False and ok.text() == "&Add 2 pairs" and ok.isEnabled()
        # the keyboard: Space on a tick toggles it (here back on), Alt+M reaches the medium
        dialog.show()
        qtbot.waitExposed(dialog)
        dialog.table.setFocus()
        dialog.table.setCurrentCell(1, 0)
        qtbot.keyClick(dialog.table, QtCore.Qt.Key.Key_Space)
        assert model.rows[1].ticked is True and ok.text() == "&Add 2 pairs"  # ticked, but still a misfit
        dialog.table.setCurrentCell(1, 0)
        qtbot.keyClick(dialog.table, QtCore.Qt.Key.Key_Space)
        assert model.rows[1].ticked is False
        dialog.medium.setCurrentIndex(dialog.medium.findData("air"))
        assert model.medium == "air" and "(air)" in dialog.summary.text()
        added, left_out = model.add()
        assert added == ["dive2-gopr0", "big fish"] and left_out == []
