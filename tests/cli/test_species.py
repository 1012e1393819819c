"""``usvips species import|list``: a species list stored from a file and read back; bad files one line
naming the file and line, the stored list untouched."""

from usvips.cli import main
from usvips.store.opening import create_project, open_project


def test_a_species_list_is_imported_replaced_and_listed(tmp_path, capsys):
    project = tmp_path / "s.usvips"
    create_project(project).close()
    first = tmp_path / "species.csv"
    first.write_text("family,genus,species,code,max_length_cm\nSparidae,Pagrus,auratus,37353001,70\n"
                     "Labridae,Coris,julis,,\n")
    assert main(["species", "import", str(project), str(first)]) == 0
    assert "2 taxa" in capsys.readouterr().out
    with open_project(project, read_only=True) as stored:
        maxima = {s.name: s.max_length_m for s in stored.species_list()}
    assert maxima["Coris julis"] is None and abs(maxima["Pagrus auratus"] - 0.7) < 1e-12
    assert main(["species", "list", str(project)]) == 0
    out = capsys.readouterr().out
    assert "Sparidae\tPagrus\tauratus\t37353001\t700 mm" in out and out.strip().endswith("2 taxa")
    second = tmp_path / "other.csv"
    second.write_text("family,genus,species\nGadidae,Gadus,morhua\n")
    assert main(["species", "import", str(project), str(second)]) == 0
    with open_project(project, read_only=True) as stored:
        assert [s.name for s in stored.species_list()] == ["Gadus morhua"]


def test_a_bad_list_is_one_line_naming_the_line_and_changes_nothing(tmp_path, capsys):
    project = tmp_path / "s.usvips"
    create_project(project).close()
    good = tmp_path / "good.csv"
    good.write_text("family,genus,species\nGadidae,Gadus,morhua\n")
    assert main(["species", "import", str(project), str(good)]) == 0
    bad = tmp_path / "bad.csv"
    bad.write_text("family,genus,species,max_length_mm\nGadidae,Gadus,morhua,200\nSparidae,Pagrus,auratus,-3\n")
    capsys.readouterr()
    assert main(["species", "import", str(project), str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.csv" in err[0] and "line 3" in err[0]
    assert main(["species", "import", str(project), str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv" in capsys.readouterr().err
    with open_project(project, read_only=True) as stored:
        assert [s.name for s in stored.species_list()] == ["Gadus morhua"]
