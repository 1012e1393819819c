from pathlib import Path

import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.io.tables import read_control, read_observations, write_control, write_observations

SAMPLE = Path(__file__).resolve().parents[2] / "sample_projects" / "tank_1995"


def test_the_thesis_tables_read_as_published():
    control = read_control(SAMPLE / "control_table3_1.csv")
    assert len(control) == 24 and control.sigmas is None
    assert control.xyz[control.index_of(["3"])[0], 2] == 100.0  # the typo is kept, not edited
    check = read_observations(SAMPLE / "water_pair2_check_table3_8.csv")
    assert check.ids[0] == "6" and set(check.extra) == {"dX", "dY", "dZ"}
    assert check.lines[0] == 3  # two comment lines before the header


@pytest.mark.parametrize("text, message", [
    ("", "no header line"),
    ("# only a comment\n", "no header line"),
    ("id,X,Y,Z\n", "no data rows"),
    ("id,X,Y\n1,2,3\n", "missing column(s) Z"),
    ("id,X,Y,Z\n1,2,3\n", "line 2: 3 fields but the header has 4"),
    ("id,X,Y,Z\n1,2,3,nan\n", "line 2: column Z: 'nan' is not a finite number"),
    ("id,X,Y,Z\n1,2,3,4\n1,5,6,7\n", "line 3: duplicate id '1' (first on line 2)"),
    ("id,X,Y,Z,sX,sY,sZ\n1,2,3,4,0.1,-1,0\n", "line 2: control sigmas must be >= 0"),
    ("id,X,Y,Z,sZ\n1,2,3,4,0.1\n", "the header has sZ but not sX, sY: control sigmas need all of sX, sY, sZ"),
])
def test_bad_control_files_name_file_and_line(tmp_path, text, message):
    path = tmp_path / "c.csv"
    path.write_text(text)
    with pytest.raises(InputFileError) as error:
        read_control(path)
    assert str(path) in str(error.value) and message in str(error.value)


def test_observation_pairs_and_round_trip(tmp_path):
    path = tmp_path / "o.csv"
    path.write_text("# pixels\nid,xl,yl,xr,yr,pair\n1,1,2,3,4,A\n1,5,6,7,8,B\n2,1,1,1,1,A\n")
    obs = read_observations(path)
    assert obs.pair_labels == ("A", "B") and len(obs.pair("A")) == 2
    write_observations(tmp_path / "back.csv", obs)
    again = read_observations(tmp_path / "back.csv")
    np.testing.assert_allclose(again.left, obs.left)
    assert again.pairs == obs.pairs
    path.write_text("id,xl,yl,xr,yr,pair\n1,1,2,3,4,A\n1,5,6,7,8,A\n")
    with pytest.raises(InputFileError, match="duplicate id '1' in pair 'A'"):
        read_observations(path)
    control = read_control(SAMPLE / "control_table3_1.csv")
    write_control(tmp_path / "c.csv", control)
    np.testing.assert_allclose(read_control(tmp_path / "c.csv").xyz, control.xyz)


@pytest.mark.parametrize("content, message", [
    (b"id,X,Y,Z\n1,2,3,\x004\n", "line 2: binary data"),
    (b"id,X,Y,Z\n1," + b"9" * 200_000 + b",3,4\n", "line 2: the line is 200006 characters long"),
    (b"id,X,Y,Z\n1,2,3,4\n\xff\xfe,1,2,3\n", "line 3: not a text"),
    (b'id,X,Y,Z\n1,2,3,"4\n', "line 2: not a valid CSV line"),
    (b"id,X,Y,Z\n1," + b"9" * 5000 + b",3,4\n", "line 2: field 2 is 5000 characters long"),
    (b"id,X,Y,Z\n1,2,3,four-point-" + b"x" * 100 + b"\n", "'four-point-xxxxxxxxxx'… is not a number"),
])
def test_hostile_csv_content_is_one_line_naming_the_line(tmp_path, content, message):
    path = tmp_path / "c.csv"
    path.write_bytes(content)
    with pytest.raises(InputFileError) as caught:
        read_control(path)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_short_rows_in_a_picks_file_are_named(tmp_path):
    path = tmp_path / "picks.csv"
    path.write_text("id,xl,yl,xr,yr,pair\n1,1,2,3,4,a\n2,1,2\n")
    with pytest.raises(InputFileError, match="line 3: 3 fields but the header has 6"):
        read_observations(path)


@pytest.mark.parametrize("text, message", [
    ("object,type,vertex,xl,yl,xr,yr\nf,line,0,1,2\n", "line 2: 5 fields but the header has 7"),
    ("object,type,vertex,xl,yl,xr,yr\nf,line,0,1,2,3,\x004\n", "line 2: binary data"),
    ("object,type,vertex,xl,yl,xr,yr\nf,line,0.5,1,2,3,4\n", "line 2: vertex and pixel columns must be numbers"),
    ("object,type,vertex,xl,yl,xr,yr\n,line,0,1,2,3,4\n", "line 2: empty id"),
    ("object,type,vertex,xl,yl\nf,line,0,1,2\n", "missing column(s) xr, yr"),
])
def test_bad_picks_name_the_line(tmp_path, text, message):
    from usvips.io.tables import read_picks

    path = tmp_path / "picks.csv"
    path.write_text(text)
    with pytest.raises(InputFileError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_picks(path)


@pytest.mark.parametrize("text, message", [
    ("id,xl,yl,xr,yr\n1,1,2,3,4\n2,1,x,3,4\n", "line 3: column yl: 'x' is not a number"),
    ("id,xl,yl,xr,yr\n1,1,2,3,4\n2,1,2,3,inf\n", "line 3: column yr: 'inf' is not a finite number"),
    ("id,xl,yl,xr,yr\n1,1,2,3,4\n\n# note\n2,1,2,,4\n", "line 5: column xr: '' is not a number"),
])
def test_bad_observation_pixels_are_named_by_line_and_column(tmp_path, text, message):
    path = tmp_path / "o.csv"
    path.write_text(text)
    with pytest.raises(InputFileError) as error:
        read_observations(path)
    assert str(path) in str(error.value) and message in str(error.value)


def test_quoted_fields_are_read_as_csv(tmp_path):
    path = tmp_path / "o.csv"
    path.write_text('id,xl,yl,xr,yr\n"fish 1, snout", 1.5 ,2,3,4\nplain,5,6,7,8\n')
    obs = read_observations(path)
    assert obs.ids == ("fish 1, snout", "plain")
    np.testing.assert_array_equal(obs.left, [[1.5, 2.0], [5.0, 6.0]])
    np.testing.assert_array_equal(obs.right, [[3.0, 4.0], [7.0, 8.0]])


SPREADSHEET_EXPORTS = [
    (b"id,X,Y,Z,,\n1,0,0,0,,\n2,1,0,0,,\n", r"line 1: column 5 of the header has no name \(and 1 more\): a value "
                                             r"under it would be read by no one"),
    (b"id,X,Y,Z,\n1,0,0,0,7\n", r"line 1: column 5 of the header has no name: "),
    (b"id;X;Y;Z\n1;0;0;0\n", r"separated by semicolons, not commas; save it as comma-separated CSV"),
    (b"id\tX\tY\tZ\n1\t0\t0\t0\n", r"the header has id X Y Z .*separated by tabs, not commas"),
    ("id,X,Y,Z\n1,0,0,0\n".encode("utf-16"), r"is UTF-16 text, not UTF-8: save it as a UTF-8 CSV file"),
]


@pytest.mark.parametrize(("content", "message"), SPREADSHEET_EXPORTS)
def test_what_a_spreadsheet_writes_is_named_with_what_to_do(tmp_path, content, message):
    """Empty columns (a value under one would be read by no one, never silently dropped), another separator
    and UTF-16 text are each named in one line that says how to save the file."""
    path = tmp_path / "control.csv"
    path.write_bytes(content)
    with pytest.raises(InputFileError, match=message) as raised:
        read_control(path)
    assert "\n" not in str(raised.value) and "\t" not in str(raised.value)
