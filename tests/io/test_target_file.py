"""Target files round-trip and refuse bad input by file and field; the printable PDF is at true scale."""

import json
import re
import zlib

import numpy as np
import pytest

from tests.core.calibration_targets.test_target_kinds import GOOD
from usvips.core.calibration_targets import from_description
from usvips.core.errors import InputFileError
from usvips.io.target_file import (
    POINTS_PER_METRE,
    VERSION,
    page_size,
    read_target,
    target_to_dict,
    write_printable,
    write_target,
)


@pytest.mark.parametrize("name", list(GOOD))
def test_a_target_file_round_trips(tmp_path, name):
    target = from_description(GOOD[name])
    path = tmp_path / "target.json"
    write_target(path, target)
    data = json.loads(path.read_text())
    assert data["format"] == "usvips-target" and data["version"] == VERSION
    again = read_target(path)
    assert again.describe() == target.describe()


def _write(tmp_path, data) -> str:
    path = tmp_path / "board.json"
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return str(path)


BAD = [
    ({**target_to_dict(from_description(GOOD["chessboard"])), "version": VERSION + 1}, "'version'", "newer"),
    ({**target_to_dict(from_description(GOOD["chessboard"])), "version": "1"}, "'version'", "whole number"),
    ({**GOOD["chessboard"]}, "format", "not a USVIPS target file"),
    ({"format": "usvips-target", "version": 1}, "'kind'", "missing"),
    ({"format": "usvips-target", "version": 1, "kind": "checkerboard"}, "'kind'", "unknown target kind"),
    ({**target_to_dict(from_description(GOOD["chessboard"])), "square": 0}, "'square'", "> 0"),
    ({**target_to_dict(from_description(GOOD["charuco"])), "marker": 0.04}, "'marker'", "smaller than the square"),
    ({**target_to_dict(from_description(GOOD["charuco"])), "cols": 30, "rows": 30}, "'dictionary'", "has 100"),
    ({**target_to_dict(from_description(GOOD["chessboard"])), "sqaure": 0.02}, "'sqaure'", "not a field"),
    ('{"format": "usvips-target",\n "version": 1,\n "kind": }', "line 3", "not valid JSON"),
    ("[1, 2]", "format", "not a USVIPS target file"),
]


@pytest.mark.parametrize(("data", "where", "words"), BAD)
def test_a_bad_target_file_is_one_line_naming_file_and_field(tmp_path, data, where, words):
    path = _write(tmp_path, data)
    with pytest.raises(InputFileError) as caught:
        read_target(path)
    message = str(caught.value)
    assert message.startswith(path) and where in message and words in message and "\n" not in message


def test_missing_and_folder_paths_are_named(tmp_path):
    with pytest.raises(InputFileError, match="no such file"):
        read_target(tmp_path / "none.json")
    with pytest.raises(InputFileError, match="is a folder"):
        read_target(tmp_path)


def _page_paths(pdf: bytes) -> tuple[list[list[tuple[float, float]]], tuple[float, float]]:
    """The filled paths of the PDF's page (lists of subpaths of points) and its MediaBox size (points)."""
    box = [float(v) for v in re.search(rb"/MediaBox \[([^\]]*)\]", pdf).group(1).split()]
    content = None
    for match in re.finditer(rb"stream\r?\n(.*?)\r?\nendstream", pdf, re.S):
        try:
            text = zlib.decompress(match.group(1))
        except zlib.error:
            continue
        if b" re W n" in text or b" m\n" in text:
            content = text.decode("latin-1")
            break
    paths, subpaths, current, numbers = [], [], [], []
    for token in content.split():
        if token in ("m", "l"):
            if token == "m" and current:
                subpaths.append(current)
                current = []
            current.append((float(numbers[-2]), float(numbers[-1])))
        elif token in ("f", "f*", "B", "S", "n") and (current or subpaths):
            paths.append(subpaths + ([current] if current else []))
            subpaths, current = [], []
        try:
            numbers.append(float(token))
        except ValueError:
            pass
    return paths, (box[2] - box[0], box[3] - box[1])


def test_the_printed_chessboard_is_at_true_scale(tmp_path):
    board = from_description(GOOD["chessboard"])  # 9 x 6 inner corners, 24 mm squares
    out = tmp_path / "board.pdf"
    width, height = write_printable(out, board)
    paths, (box_w, box_h) = _page_paths(out.read_bytes())
    assert box_w == pytest.approx(width * POINTS_PER_METRE, abs=1e-3)
    assert box_h == pytest.approx(height * POINTS_PER_METRE, abs=1e-3)
    squares = max(paths, key=len)
    assert len(squares) == len(board.shapes()[0]) == 35
    square_pt = 0.024 * POINTS_PER_METRE
    for subpath in squares:
        xs, ys = np.array(subpath).T
        assert xs.max() - xs.min() == pytest.approx(square_pt, abs=2e-6)
        assert ys.max() - ys.min() == pytest.approx(square_pt, abs=2e-6)
    corners = np.vstack([np.array(s) for s in squares])
    assert corners[:, 0].max() - corners[:, 0].min() == pytest.approx(10 * square_pt, abs=2e-5)
    assert corners[:, 1].max() - corners[:, 1].min() == pytest.approx(7 * square_pt, abs=2e-5)
    # the whole sheet fits the page, inside the margins
    x0, y0, x1, y1 = board.sheet()
    assert (x1 - x0) * POINTS_PER_METRE < box_w and (y1 - y0) * POINTS_PER_METRE < box_h


def test_a_large_board_gets_a_large_enough_page_and_a_small_one_a4(tmp_path):
    large = from_description({"kind": "charuco", "dictionary": "6X6_250", "cols": 14, "rows": 10, "square": 0.06,
                              "marker": 0.045})
    width, height = page_size(large)
    x0, y0, x1, y1 = large.sheet()
    assert width >= x1 - x0 + 0.03 and height >= y1 - y0 + 0.03
    small = from_description({"kind": "chessboard", "cols": 5, "rows": 4, "square": 0.01})
    assert sorted(page_size(small)) == pytest.approx([0.210, 0.297])


def test_printing_refuses_a_target_field_and_a_wrong_extension(tmp_path):
    with pytest.raises(InputFileError, match="not a printed board"):
        write_printable(tmp_path / "field.pdf", from_description(GOOD["target-field"]))
    with pytest.raises(InputFileError, match=r"\.pdf"):
        write_printable(tmp_path / "board.png", from_description(GOOD["chessboard"]))
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("name", ["charuco", "marker-grid", "circle-grid"])
def test_every_board_kind_prints(tmp_path, name):
    out = tmp_path / "board.pdf"
    write_printable(out, from_description(GOOD[name]))
    assert out.read_bytes().startswith(b"%PDF")
