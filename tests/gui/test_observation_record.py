"""The observation record: a species list imported from CSV (EventMeasure / CheckEM columns), a
keyboard-driven form after each measurement, the fields stored in the project (schema 5)."""

import sqlite3

import pytest
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import click_pixel, isolated_targets, open_sample, truth_pixels
from usvips.core.errors import InputFileError, InvalidParameterError
from usvips.core.observation_record import ObservationRecord, Species
from usvips.io.species_list import read_species_list
from usvips.store import Project
from usvips.store.project import FORMAT, migrate
from usvips.store.schema import MIGRATIONS

SPECIES = """# a CheckEM-style list
Family,Genus,Species,CAAB_code
Sparidae,Pagrus,auratus,37353001
Labridae,Notolabrus,gymnogenis,37384043
Labridae,Coris,picta,37384027
Carangidae,Trachurus,novaezelandiae,37337002
"""


def _write(tmp_path, text, name="species.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_species_list_is_read_with_its_columns_and_bad_lines_are_named(tmp_path):
    species = read_species_list(_write(tmp_path, SPECIES))
    assert [s.name for s in species] == ["Pagrus auratus", "Notolabrus gymnogenis", "Coris picta",
                                         "Trachurus novaezelandiae"]
    assert species[0] == Species("Sparidae", "Pagrus", "auratus", "37353001")
    with pytest.raises(InputFileError, match=r"line 2: the header lacks family"):
        read_species_list(_write(tmp_path, "\nGenus,Species\nPagrus,auratus\n", "a.csv"))
    with pytest.raises(InputFileError, match=r"line 3: Pagrus auratus is listed twice \(also on line 2\)"):
        read_species_list(_write(tmp_path, "family,genus,species\nSparidae,Pagrus,auratus\nSparidae,Pagrus,auratus\n",
                                 "b.csv"))
    with pytest.raises(InputFileError, match=r"line 2: .*genus.*must not be empty"):
        read_species_list(_write(tmp_path, "family,genus,species\nSparidae,,auratus\n", "c.csv"))
    with pytest.raises(InvalidParameterError, match="number"):
        ObservationRecord(number=0)
    with pytest.raises(InvalidParameterError, match="comment"):
        ObservationRecord(comment="two\tcolumns")


def test_an_old_project_gains_the_record_tables_and_keeps_its_objects(tmp_path):
    path = tmp_path / "old.usvips"
    connection = sqlite3.connect(path)
    migrate(connection, 2)  # a project as the releases before schema 5 made it
    with connection:
        connection.executemany("INSERT INTO meta VALUES (?, ?)", [("format", FORMAT), ("created", "then")])
        connection.execute("INSERT INTO objects (kind, created, modified) VALUES ('point', 'then', 'then')")
    connection.close()
    with Project.open(path) as project:
        assert project.version == max(MIGRATIONS) >= 5
        (old,) = project.objects()
        assert project.record(old.id) is None
        project.set_record(old.id, ObservationRecord.of(Species("Sparidae", "Pagrus", "auratus"), number=2))
        project.set_species_list(read_species_list(_write(tmp_path, SPECIES)))
        assert len(project.species_list()) == 4 and project.record(old.id).number == 2


def test_after_a_measurement_the_form_takes_the_keys_and_stores_the_record(qtbot, make_window, sample_copy,
                                                                         tmp_path):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    assert window.import_species(_write(tmp_path, SPECIES))
    window.set_tool("point")
    left, right = truth_pixels(directory, "water1", "targets")
    numbers = isolated_targets(left, right)[:2]
    click_pixel(qtbot, window.panes["left"], left[numbers[0]])
    click_pixel(qtbot, window.panes["right"], right[numbers[0]])
    (stored,) = window.workspace.project.objects()
    form = window.observation
    assert form.object_id == stored.id
    qtbot.waitUntil(lambda: QtWidgets.QApplication.focusWidget() is form.species, timeout=2000)
    qtbot.keyClicks(form.species, "labrus gym")  # type-ahead matches inside the name
    completer = form.species.completer()
    assert completer.currentCompletion().startswith("Notolabrus gymnogenis")
    form.species.setEditText(completer.currentCompletion())
    qtbot.keyClick(form.species, QtCore.Qt.Key.Key_Tab)
    focus = QtWidgets.QApplication.focusWidget()
    focus.selectAll()
    qtbot.keyClicks(focus, "3")  # the number
    form.stage.setEditText("J")
    form.comment.setText("in the kelp")
    form.keep.setChecked(True)
    qtbot.keyClick(QtWidgets.QApplication.focusWidget(), QtCore.Qt.Key.Key_Return)
    record = window.workspace.project.record(stored.id)
    assert record == ObservationRecord("Labridae", "Notolabrus", "gymnogenis", "37384043", 3, "J", "", "in the kelp")
    assert QtWidgets.QApplication.focusWidget() is window.panes["left"].graphics  # back to measuring
    listing = window.object_list
    row = listing.row_of(stored.id)
    assert listing.text(row, "species") == "Notolabrus gymnogenis × 3"  # one place: the record
    assert listing.text(row, "pair") == "water1"
    # the next measurement starts with the kept values; a species not in the list is refused, nothing lost
    click_pixel(qtbot, window.panes["left"], left[numbers[1]])
    click_pixel(qtbot, window.panes["right"], right[numbers[1]])
    second = window.workspace.project.objects()[-1]
    assert form.object_id == second.id and form.number.value() == 3
    form.species.setEditText("Nemo unknownus")
    assert not form.store()
    assert "not in the project's species list" in form.status.text()
    assert form.species.currentText() == "Nemo unknownus" and window.workspace.project.record(second.id) is None
    form.species.setEditText("auratu")  # type-ahead: the one entry containing it is taken (Tab or Enter)
    assert form.store() and window.workspace.project.record(second.id).name == "Pagrus auratus"
    form.species.setEditText("37353001")  # by code
    assert form.store()
    assert window.workspace.project.record(second.id).name == "Pagrus auratus"
    window.undo()
    window.undo()  # both records of the second object taken back
    assert window.workspace.project.record(second.id) is None
    window.redo()
    window.redo()
    path = window.workspace.project.path
    window.close()
    with Project.open(path) as again:
        assert again.record(stored.id).number == 3 and again.record(second.id).code == "37353001"


def test_the_object_list_is_in_front_again_after_the_record_is_stored_or_skipped(qtbot, make_window, sample_copy):
    """The form is raised over the object list after a measurement; Enter or Esc puts the list (showing
    the new object's figure) in front again, and the images get the keyboard."""
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    window.set_tool("point")
    left, right = truth_pixels(directory, "water1", "targets")
    numbers = isolated_targets(left, right)[:2]

    def in_front(dock) -> bool:
        return not dock.visibleRegion().isEmpty()

    for number, key in zip(numbers, (QtCore.Qt.Key.Key_Escape, QtCore.Qt.Key.Key_Return), strict=True):
        window.docks["objects"].raise_()
        qtbot.waitUntil(lambda: in_front(window.docks["objects"]), timeout=2000)
        click_pixel(qtbot, window.panes["left"], left[number])
        click_pixel(qtbot, window.panes["right"], right[number])
        qtbot.waitUntil(lambda: in_front(window.docks["observation"]), timeout=2000)
        assert not in_front(window.docks["objects"])
        qtbot.waitUntil(lambda: QtWidgets.QApplication.focusWidget() is window.observation.species, timeout=2000)
        qtbot.keyClick(window.observation.species, key)
        qtbot.waitUntil(lambda: in_front(window.docks["objects"]), timeout=2000)
        assert QtWidgets.QApplication.focusWidget() is window.panes["left"].graphics
    # the plan view in front instead: the form leaves it in front again too
    window.docks["plan"].raise_()
    qtbot.waitUntil(lambda: in_front(window.docks["plan"]), timeout=2000)
    window.workspace.stored.emit(window.workspace.object_ids()[0])
    qtbot.waitUntil(lambda: in_front(window.docks["observation"]), timeout=2000)
    qtbot.keyClick(window.observation.species, QtCore.Qt.Key.Key_Escape)
    qtbot.waitUntil(lambda: in_front(window.docks["plan"]), timeout=2000)


def test_the_form_forgets_an_object_whose_store_is_undone(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    window.set_tool("point")
    left, right = truth_pixels(directory, "water1", "targets")
    number = isolated_targets(left, right)[0]
    click_pixel(qtbot, window.panes["left"], left[number])
    click_pixel(qtbot, window.panes["right"], right[number])
    (stored,) = window.workspace.project.objects()
    form = window.observation
    assert form.object_id == stored.id and form.target.text() != "no object"
    form.comment.setText("by the rock")
    window.undo()  # the store taken back: the form no longer offers a record for an object that is gone
    assert window.workspace.project.objects() == []
    assert form.object_id is None and form.target.text() == "no object" and form.comment.text() == ""
    assert "no longer in the project" in form.status.text()
    assert not form.store() and window.workspace.project.objects() == []
