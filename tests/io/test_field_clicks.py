"""The clicks file of a target field (side,id,x,y): written and read back, every error naming the file and
the line."""

import pytest

from usvips.core.errors import InputFileError
from usvips.io.field_clicks import read_clicks, write_clicks


def test_written_clicks_read_back(tmp_path):
    pixels = {"left": {"T01": (412.5, 233.0), "a,b": (1.25, 2.0)}, "right": {"T01": (300.126, 230.4)}}
    write_clicks(tmp_path / "c.csv", pixels)
    clicks = read_clicks(tmp_path / "c.csv")
    assert clicks.pixels == {"left": {"T01": (412.5, 233.0), "a,b": (1.25, 2.0)}, "right": {"T01": (300.13, 230.4)}}
    assert clicks.lines == {("left", "T01"): 2, ("left", "a,b"): 3, ("right", "T01"): 4}


@pytest.mark.parametrize("text,message", [
    ("side,id,x\nleft,T1,3\n", "missing column(s) y"),
    ("side,id,x,y\nleft,T1,3,4\n# a comment\nLEFT,T1,5,6\n", "line 4: target 'T1' is identified twice in the "
                                                             "left image (first on line 2)"),
    ("side,id,x,y\nleft,T1,3,four\n", "line 2: column y: 'four' is not a number"),
    ("side,id,x,y\nleft,T1,3,nan\n", "line 2: column y: 'nan' is not a finite number"),
    ("side,id,x,y\nup,T1,3,4\n", "line 2: side 'up' is neither left nor right"),
    ("side,id,x,y\nleft,,3,4\n", "line 2: empty id"),
    ("side,id,x,y\n", "a header but no data rows"),
])
def test_bad_clicks_files_are_named(tmp_path, text, message):
    path = tmp_path / "clicks.csv"
    path.write_text(text)
    with pytest.raises(InputFileError, match=message.replace("(", r"\(").replace(")", r"\)")) as error:
        read_clicks(path)
    assert str(error.value).startswith(str(path))
