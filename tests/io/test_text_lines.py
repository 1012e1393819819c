"""Lines numbered as an editor numbers them (usvips.io.text_lines) in every text table a user hands in: a line
ends at CR LF, CR or LF only, so an error names the line the user sees in a Windows, classic-Mac or Unix file,
and a control character in a field is refused by its line, never stored."""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.io.observation_stream import observation_chunks
from usvips.io.species_list import read_species_list
from usvips.io.tables import read_control, read_observations
from usvips.io.text_lines import last_break_end, line_of_offset, split_lines

BREAKS = ("\n", "\r\n", "\r")
#: what str.splitlines breaks at that an editor shows inside a line
INSIDE = ("\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029")


@pytest.mark.parametrize("seed", range(20))
def test_lines_split_at_every_usual_break_and_nowhere_else(seed):
    rng = np.random.default_rng(seed)
    # (no empty line: a CR ending one line and an LF ending an empty next one read as one CR LF)
    lines = ["".join(rng.choice(list("ab,1.") + list(INSIDE), size=int(rng.integers(1, 6)))) for _ in range(12)]
    breaks = [str(rng.choice(BREAKS)) for _ in lines]
    text = "".join(line + end for line, end in zip(lines, breaks, strict=True))
    assert split_lines(text) == lines
    assert split_lines(text[:-len(breaks[-1])]) == lines  # the last line without its break
    data, starts = b"", []
    for line, end in zip(lines, breaks, strict=True):
        starts.append(len(data))
        data += (line + end).encode("utf-8")
    assert [line_of_offset(data, start) for start in starts] == list(range(1, len(lines) + 1))


def test_a_block_never_ends_inside_a_cr_lf():
    assert last_break_end(b"ab\r\ncd\r", more=True) == 4  # the final CR may be half of a CR LF
    assert last_break_end(b"ab\r\ncd\r", more=False) == 7
    assert last_break_end(b"ab\rcd", more=True) == 3 and last_break_end(b"abcd", more=True) == 0


def _observations(rows: list[str], breaks: str) -> str:
    return breaks.join(["id,xl,yl,xr,yr,pair", *rows]) + breaks


@pytest.mark.parametrize("breaks", BREAKS)
@pytest.mark.parametrize("block_bytes", [7, 64, 1 << 16])
def test_an_error_names_the_line_an_editor_shows_whatever_the_breaks(tmp_path, breaks, block_bytes):
    good = [f"{i},{i}.5,2,3,4,p" for i in range(1, 9)]
    path = tmp_path / "obs.csv"
    path.write_bytes(_observations(good[:5] + ["6,1,2,3,x,p"] + good[6:], breaks).encode())
    with pytest.raises(InputFileError, match=r"line 7: column yr: 'x' is not a number"):
        read_observations(path)
    with pytest.raises(InputFileError, match=r"line 7: column yr: 'x' is not a number"):
        list(observation_chunks(path, rows=3, block_bytes=block_bytes))
    path.write_bytes(_observations(good, breaks).encode())
    chunks = list(observation_chunks(path, rows=3, block_bytes=block_bytes))
    assert [i for chunk in chunks for i in chunk.ids] == [str(i) for i in range(1, 9)]
    assert [n for chunk in chunks for n in chunk.lines] == list(range(2, 10))
    path.write_bytes(_observations(good, breaks).encode().replace(b"4.5", b"4\xff5"))  # not UTF-8, on line 5
    for read in (read_observations, lambda p: list(observation_chunks(p, block_bytes=block_bytes))):
        with pytest.raises(InputFileError, match=r"line 5: not a text \(UTF-8\) CSV file"):
            read(path)


@pytest.mark.parametrize("character", INSIDE + ("\x01", "\x1b", "\x7f"))
def test_a_control_character_in_a_field_is_refused_by_its_line(tmp_path, character):
    path = tmp_path / "control.csv"
    path.write_text(f"id,X,Y,Z\n1,0,0,0\n2,1,0,0\nrock{character}3,1,1,0\n4,0,1,1\n", encoding="utf-8", newline="")
    message = rf"line 4: a control character \(U\+{ord(character):04X}\) in the line"
    with pytest.raises(InputFileError, match=message):
        read_control(path)
    obs = tmp_path / "obs.csv"
    obs.write_text(_observations(["1,1,2,3,4,p", f"2,1,2,3,4,p{character}q"], "\n"), encoding="utf-8", newline="")
    with pytest.raises(InputFileError, match=message.replace("line 4", "line 3")):
        list(observation_chunks(obs))
    species = tmp_path / "species.csv"
    species.write_text(f"family,genus,species\nSparidae,Pagrus,auratus\nLabridae,Notolabrus{character},celidotus\n",
                       encoding="utf-8", newline="")
    with pytest.raises(InputFileError, match=message.replace("line 4", "line 3")):
        read_species_list(species)


def test_a_utf16_observation_file_is_named_as_such_by_the_stream_too(tmp_path):
    path = tmp_path / "obs.csv"
    path.write_bytes(_observations(["1,1,2,3,4,p"], "\r\n").encode("utf-16"))
    for read in (read_observations, lambda p: list(observation_chunks(p))):
        with pytest.raises(InputFileError, match=r"is UTF-16 text, not UTF-8: save it as a UTF-8 CSV file"):
            read(path)


@pytest.mark.parametrize("reader", ["calibration", "target", "dlt"])
def test_json_and_dlt_files_not_in_utf8_are_named_by_line_or_as_utf16(tmp_path, reader):
    """A calibration, target or DLT file saved as UTF-16 (Windows PowerShell's default) says so; a bad byte
    is named by its line, counted as an editor counts it (here a classic-Mac file, CR only)."""
    from usvips.io.calibration_file import load_calibration
    from usvips.io.dlt_coefficients import read_coefficients
    from usvips.io.target_file import read_target

    read, what = {"calibration": (load_calibration, "calibration file"), "target": (read_target, "target file"),
                  "dlt": (read_coefficients, "file of DLT coefficients")}[reader]
    path = tmp_path / "file.txt"
    path.write_bytes('{\n  "version": 1\n}\n'.encode("utf-16"))
    with pytest.raises(InputFileError, match=f"is UTF-16 text, not UTF-8: save it as a UTF-8 {what}"):
        read(path)
    path.write_bytes(b'{\r  "version": 1,\r  "name": "b\xffd"\r}\r')
    with pytest.raises(InputFileError, match=rf"line 3: not a text \(UTF-8\) {what}"):
        read(path)
