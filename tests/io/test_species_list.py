"""Species lists with the species' maximum length (CheckEM's rule), its unit named by the header."""

import pytest

from usvips.core.errors import InputFileError
from usvips.io.species_list import read_species_list


@pytest.mark.parametrize("header, cell, metres", [("max_length_mm", "450", 0.45), ("max_length_cm", "45", 0.45),
                                                   ("fb_length_max", "130", 1.3), ("Max_Length_M", "0.9", 0.9)])
def test_the_maximum_length_is_read_in_its_unit_and_an_empty_cell_is_no_maximum(tmp_path, header, cell, metres):
    path = tmp_path / "species.csv"
    path.write_text(f"family,genus,species,code,{header}\nSparidae,Pagrus,auratus,37353001,{cell}\n"
                    "Labridae,Achoerodus,gouldii,37384040,\n")
    first, second = read_species_list(path)
    assert first.max_length_m == pytest.approx(metres) and second.max_length_m is None


def test_a_list_without_the_column_has_no_maxima(tmp_path):
    path = tmp_path / "species.csv"
    path.write_text("family,genus,species\nSparidae,Pagrus,auratus\n")
    assert read_species_list(path)[0].max_length_m is None


@pytest.mark.parametrize("header, cell, words", [
    ("max_length", "450", r"line 1: the column 'max_length' needs its unit"),
    ("max_length_mm", "long", r"line 2: the maximum length 'long' is not a number"),
    ("max_length_mm", "-3", r"line 2: the maximum length -3 \(max_length_mm\) must be a positive number"),
    ("max_length_cm", "nan", r"line 2: the maximum length nan \(max_length_cm\) must be a positive number"),
    ("max_length_mm,max_length_cm", "1,2", r"line 1: 2 maximum-length columns \(max_length_mm, max_length_cm\)"),
    ("caab", "1", r"line 1: the columns 'code' and 'caab' both give the code"),
])
def test_a_bad_maximum_is_named_with_its_file_and_line(tmp_path, header, cell, words):
    path = tmp_path / "species.csv"
    code = ",code" if header == "caab" else ""
    path.write_text(f"family,genus,species{code},{header}\nSparidae,Pagrus,auratus{',7' if code else ''},{cell}\n")
    with pytest.raises(InputFileError, match=words):
        read_species_list(path)


def test_a_species_list_not_in_utf8_is_named_by_its_line_or_as_utf16(tmp_path):
    from usvips.core.errors import InputFileError

    path = tmp_path / "species.csv"
    path.write_bytes("family,genus,species\nSparidae,Pagrus,auratus\n".encode("utf-16"))
    with pytest.raises(InputFileError, match="is UTF-16 text, not UTF-8: save it as a UTF-8 species list"):
        read_species_list(path)
    path.write_bytes(b"family,genus,species\rSparidae,Pagrus,auratus\rLabridae,Noto\xfflabrus,celidotus\r")
    with pytest.raises(InputFileError, match=r"line 3: not a text \(UTF-8\) species list"):
        read_species_list(path)


@pytest.mark.parametrize(("rows", "line", "words"), [
    ('Sparidae,Chrysophrys,"aur\natus",1', 2, "not a valid CSV line"),  # a quoted line break
    ('Sparidae,Chrysophrys,"auratus,1', 2, "not a valid CSV line"),  # a quote left open
    ("Sparidae,Chrysophrys", 2, "2 fields but the header has 4"),  # a row short of a required field
    ("Sparidae,Chrysophrys,auratus,1,extra", 2, "5 fields but the header has 4"),  # a value slipped
    ("Sparidae,Chry\x00sophrys,auratus,1", 2, "NUL byte"),
    ("Sparidae,Chrysophrys,auratus,1\nsparidae,chrysophrys,Auratus,2", 3, r"listed twice \(also on line 2\)"),
])
def test_a_row_that_is_not_one_clean_taxon_is_refused_by_its_line(tmp_path, rows, line, words):
    path = tmp_path / "species.csv"
    path.write_text("family,genus,species,code\n" + rows + "\n", encoding="utf-8")
    with pytest.raises(InputFileError, match=words) as raised:
        read_species_list(path)
    assert raised.value.line == line and "\n" not in str(raised.value)


@pytest.mark.parametrize("cell", ["1_30", "١٣٠", "130,5"])
def test_a_maximum_length_that_another_program_reads_as_text_is_refused(tmp_path, cell):
    path = tmp_path / "species.csv"
    path.write_text(f'family,genus,species,max_length_cm\nSparidae,Chrysophrys,auratus,"{cell}"\n', encoding="utf-8")
    with pytest.raises(InputFileError, match="is not a number"):
        read_species_list(path)


def _read(tmp_path, text: str):
    path = tmp_path / "species.csv"
    path.write_text(text, encoding="utf-8")
    return read_species_list(path)


def test_indented_comments_padded_fields_and_optional_fields_left_off_are_read(tmp_path):
    """As every table reads them; and a row may stop after its last required field, as spreadsheets write."""
    taxa = _read(tmp_path, "family, genus ,species,code\n   # a comment\nSparidae , Chrysophrys,auratus,1\n"
                           '"Labridae","Notolabrus","gymnogenis",2\n')
    assert [s.name for s in taxa] == ["Chrysophrys auratus", "Notolabrus gymnogenis"]
    with pytest.raises(InputFileError, match="separated by semicolons, not commas"):
        _read(tmp_path, "family;genus;species\nSparidae;Chrysophrys;auratus\n")
    taxa = _read(tmp_path, "family,genus,species,code,max_length_cm\nSparidae,Chrysophrys,auratus\n"
                           "Labridae,Notolabrus,gymnogenis,37384005\nLabridae,Achoerodus,gouldii,,120\n")
    assert [(s.name, s.code, s.max_length_m) for s in taxa] == [("Chrysophrys auratus", "", None),
                                                               ("Notolabrus gymnogenis", "37384005", None),
                                                               ("Achoerodus gouldii", "", 1.2)]
