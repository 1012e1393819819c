"""Control, observation and picks CSV files.

* Control: ``id,X,Y,Z[,sX,sY,sZ]`` — metres.
* Observations: ``id,xl,yl,xr,yr[,pair]`` — pixels (x right, y down, origin at the centre of the top-left
  pixel); any further numeric columns are kept (``extra``), e.g. the seeds' ``dX,dY,dZ``.
* Picks: ``object,type,vertex,xl,yl,xr,yr[,attribute]`` — pixels; the vertices of measured objects.

Lines starting with ``#`` and blank lines are ignored; the first other line is the header. Every error
names the file and the line.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.measurements import LEGACY, names
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.plain_numbers import plain_number
from usvips.io.atomic import write_text_atomic
from usvips.io.file_errors import not_a_file
from usvips.io.text_lines import not_utf8, refuse_control_characters, split_lines

CONTROL_COLUMNS = ("id", "X", "Y", "Z")
CONTROL_SIGMA_COLUMNS = ("sX", "sY", "sZ")
OBSERVATION_COLUMNS = ("id", "xl", "yl", "xr", "yr")
PICKS_COLUMNS = ("object", "type", "vertex", "xl", "yl", "xr", "yr")


#: Largest CSV file (bytes) and field (characters) read; a control or observation table is far smaller.
MAX_FILE_BYTES = 256 << 20
MAX_FIELD_CHARS = 4096
MAX_LINE_CHARS = 65536


def _show(text: str) -> str:
    """A field as quoted in an error message, cut short (a message is one line, not the file's content)."""
    return repr(text) if len(text) <= 24 else repr(text[:21]) + "…"


def _rows(path: Path) -> tuple[list[str], list[tuple[int, list[str]]]]:
    if not path.is_file():
        raise not_a_file(path)
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise InputFileError(str(path), f"too large for a CSV table (over {MAX_FILE_BYTES >> 20} MiB)")
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        raise not_utf8(str(path), error.object, error.start) from None
    except OSError as error:
        raise InputFileError(str(path), f"cannot read the file: {error.strerror or error}") from None
    refuse_control_characters(str(path), text)
    header: list[str] | None = None
    rows: list[tuple[int, list[str]]] = []
    for number, line in enumerate(split_lines(text), start=1):
        fields = split_line(path, number, line)
        if fields is None:
            continue
        if header is None:
            header = fields
            header_line = number
            continue
        rows.append((number, fields))
    if header is None:
        raise InputFileError(str(path), "the file has no header line")
    check_header(path, header, header_line)
    if not rows:
        raise InputFileError(str(path), "the file has a header but no data rows")
    return header, rows


def split_line(path: Path, number: int, line: str) -> list[str] | None:
    """The stripped fields of line ``number`` of a CSV table (None: a blank line or a ``#`` comment);
    :class:`InputFileError` naming the line when it is binary, too long or not valid CSV."""
    stripped = line.strip()
    if not stripped or stripped.startswith("#"):
        return None
    if "\x00" in stripped:
        raise InputFileError(str(path), "binary data (a NUL byte); not a CSV text file", number)
    if len(stripped) > MAX_LINE_CHARS:
        raise InputFileError(str(path), f"the line is {len(stripped)} characters long (at most {MAX_LINE_CHARS})",
                             number)
    try:
        # (a line without quotes splits as csv would, at a fraction of the cost of a reader per line)
        fields = [f.strip() for f in (stripped.split(",") if '"' not in stripped
                                      else next(csv.reader([stripped], strict=True)))]
    except csv.Error as error:
        raise InputFileError(str(path), f"not a valid CSV line ({error})", number) from None
    long = next((i for i, f in enumerate(fields) if len(f) > MAX_FIELD_CHARS), None)
    if long is not None:
        raise InputFileError(str(path), f"field {long + 1} is {len(fields[long])} characters long (at most "
                             f"{MAX_FIELD_CHARS})", number)
    return fields


def check_header(path: Path, header: list[str], line: int) -> None:
    """:class:`InputFileError` when a column has no name (a value under it would be read by no one) or a
    column name is given twice."""
    unnamed = [i + 1 for i, name in enumerate(header) if not name]
    if unnamed:
        more = f" (and {len(unnamed) - 1} more)" if len(unnamed) > 1 else ""
        raise InputFileError(str(path), f"column {unnamed[0]} of the header has no name{more}: a value under it "
                             "would be read by no one; name it or delete it (a spreadsheet may add empty columns)",
                             line)
    if len(set(header)) != len(header):
        raise InputFileError(str(path), f"duplicate column names in the header {','.join(header)[:80]}", line)


def separator_hint(header: list[str]) -> str:
    """": its fields are separated by semicolons (or tabs), not commas; …" when the header read as one
    column holds that separator (a spreadsheet's export in a comma-decimal locale), else ""."""
    separator = next((name for mark, name in ((";", "semicolons"), ("\t", "tabs")) if len(header) == 1
                      and mark in header[0]), None)
    return f": its fields are separated by {separator}, not commas; save it as comma-separated CSV" \
        if separator else ""


def _column_index(path: Path, header: list[str], required: tuple[str, ...]) -> dict[str, int]:
    missing = [c for c in required if c not in header]
    if missing:
        hint = separator_hint(header)
        shown = ", ".join(header)[:80].replace("\t", " ")
        raise InputFileError(str(path), f"missing column(s) {', '.join(missing)}; the header has {shown} (expected "
                             f"{','.join(required)}){hint}")
    return {name: header.index(name) for name in header}


#: no pixel coordinate lies this far from an image's origin (the largest sensors are ~10^5 px wide)
MAX_PIXEL = 1e6
#: no control coordinate lies this far from its origin (metres; Earth-centred coordinates are ~6.4e6 m)
MAX_COORDINATE = 1e8


def _number(path: Path, line: int, column: str, text: str, limit: tuple[float, str] | None = None) -> float:
    """The number in one field; ``limit``: (largest magnitude, its unit) beyond which it is no value."""
    try:
        value = plain_number(text)
    except ValueError:
        raise InputFileError(str(path), f"column {column}: {_show(text)} is not a number", line) from None
    if not math.isfinite(value):
        raise InputFileError(str(path), f"column {column}: {_show(text)} is not a finite number", line)
    if limit is not None and abs(value) > limit[0]:
        where = "the image" if limit[1] == "px" else "any survey"
        raise InputFileError(str(path), f"column {column}: {_show(text)} lies outside {where} (more than "
                             f"{limit[0]:g} {limit[1]} from the origin)", line)
    return value


def _check_width(path: Path, line: int, fields: list[str], header: list[str]) -> None:
    if len(fields) != len(header):
        raise InputFileError(str(path), f"{len(fields)} fields but the header has {len(header)} "
                             f"({','.join(header)[:80]})", line)


def _check_id(path: Path, line: int, text: str) -> str:
    if not text:
        raise InputFileError(str(path), "empty id", line)
    return text


def read_control(path: str | Path) -> ControlPoints:
    """Read a control-point file; raises :class:`InputFileError` naming the file and line."""
    path = Path(path)
    header, rows = _rows(path)
    columns = _column_index(path, header, CONTROL_COLUMNS)
    has_sigma = all(c in columns for c in CONTROL_SIGMA_COLUMNS)
    given = [c for c in CONTROL_SIGMA_COLUMNS if c in header]
    if given and not has_sigma:  # a sigma in one axis only would be ignored without a word
        missing = [c for c in CONTROL_SIGMA_COLUMNS if c not in given]
        raise InputFileError(str(path), f"the header has {', '.join(given)} but not {', '.join(missing)}: control "
                             f"sigmas need all of {', '.join(CONTROL_SIGMA_COLUMNS)} (metres) or none")
    ids, xyz, sig, lines = [], [], [], []
    first_line: dict[str, int] = {}
    places: dict[tuple[float, ...], int] = {}
    for line, fields in rows:
        _check_width(path, line, fields, header)
        pid = _check_id(path, line, fields[columns["id"]])
        if pid in first_line:
            raise InputFileError(str(path), f"duplicate id {_show(pid)} (first on line {first_line[pid]})", line)
        first_line[pid] = line
        ids.append(pid)
        lines.append(line)
        xyz.append([_number(path, line, c, fields[columns[c]], (MAX_COORDINATE, "m")) for c in ("X", "Y", "Z")])
        same = places.setdefault(tuple(xyz[-1]), len(ids) - 1)
        if same != len(ids) - 1:
            raise InputFileError(str(path), f"point {_show(pid)} has the coordinates of point {_show(ids[same])} "
                                 f"(line {lines[same]}): two targets cannot be in one place", line)
        if has_sigma:
            values = [_number(path, line, c, fields[columns[c]], (MAX_COORDINATE, "m")) for c in CONTROL_SIGMA_COLUMNS]
            if any(v < 0 for v in values):
                raise InputFileError(str(path), "control sigmas must be >= 0", line)
            sig.append(values)
    try:
        return ControlPoints(tuple(ids), np.array(xyz), np.array(sig) if has_sigma else None,
                             str(path), tuple(lines))
    except UsvipsError as error:
        raise InputFileError(str(path), str(error)) from None


def read_observations(path: str | Path) -> StereoObservations:
    """Read a stereo observation file; raises :class:`InputFileError` naming the file and line."""
    path = Path(path)
    header, rows = _rows(path)
    columns = _column_index(path, header, OBSERVATION_COLUMNS)
    extra_names = [c for c in header if c not in OBSERVATION_COLUMNS and c != "pair"]
    ids, left, right, pairs, lines = [], [], [], [], []
    extra: dict[str, list[float]] = {c: [] for c in extra_names}
    first_line: dict[tuple[str, str], int] = {}
    for line, fields in rows:
        _check_width(path, line, fields, header)
        pid = _check_id(path, line, fields[columns["id"]])
        pair = fields[columns["pair"]] if "pair" in columns else "1"
        if not pair:
            raise InputFileError(str(path), "empty pair label", line)
        key = (pair, pid)
        if key in first_line:
            raise InputFileError(str(path), f"duplicate id {_show(pid)} in pair {_show(pair)} "
                                 f"(first on line {first_line[key]})", line)
        first_line[key] = line
        ids.append(pid)
        pairs.append(pair)
        lines.append(line)
        for c in extra_names:
            text = fields[columns[c]]
            extra[c].append(_number(path, line, c, text) if text else math.nan)
    left, right = _pixel_columns(path, rows, columns, ("xl", "yl")), _pixel_columns(path, rows, columns, ("xr", "yr"))
    numeric_extra = {c: np.array(v) for c, v in extra.items()}
    return StereoObservations(tuple(ids), np.array(left), np.array(right), tuple(pairs), numeric_extra,
                              str(path), tuple(lines))


def _pixel_columns(path: Path, rows: list[tuple[int, list[str]]], columns: dict[str, int],
                   names: tuple[str, str]) -> np.ndarray:
    """Two numeric columns (N, 2) converted in bulk; where that fails, the first bad field is named."""
    first, second = columns[names[0]], columns[names[1]]
    texts = [(fields[first], fields[second]) for _, fields in rows]
    try:
        values = np.array(texts, dtype=np.float64)
        if np.all(np.isfinite(values)) and np.all(np.abs(values) <= MAX_PIXEL):
            return values
    except ValueError:
        pass
    return np.array([[_number(path, line, c, fields[columns[c]], (MAX_PIXEL, "px")) for c in names]
                     for line, fields in rows])



def read_picks(path: str | Path) -> list[dict]:
    """Read a picks file ``object,type,vertex,xl,yl,xr,yr[,attribute]`` (pixels; ``type`` a measurement
    kind; ``vertex`` a whole number). Returns one dict per row (object, type, vertex, pixels [xl, yl, xr,
    yr], attribute, line); raises :class:`InputFileError` naming the file and line."""
    path = Path(path)
    header, rows = _rows(path)
    columns = _column_index(path, header, PICKS_COLUMNS)
    picks = []
    for line, fields in rows:
        _check_width(path, line, fields, header)
        kind = fields[columns["type"]]
        if kind not in (*names(), *LEGACY):
            raise InputFileError(str(path), f"type {_show(kind)} is not one of {', '.join((*names(), *LEGACY))}",
                                 line)
        pixels = []
        for column in ("vertex", "xl", "yl", "xr", "yr"):
            text = fields[columns[column]]
            try:
                value = plain_number(text, float if column != "vertex" else int)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise InputFileError(str(path), "vertex and pixel columns must be numbers (both picks are needed); "
                                     f"column {column}: {_show(text)}", line)
            if abs(value) > MAX_PIXEL:
                raise InputFileError(str(path), f"column {column}: {_show(text)} lies outside the image (more than "
                                     f"{MAX_PIXEL:g} px from the origin)", line)
            pixels.append(value)
        vertex = int(pixels.pop(0))
        picks.append({"object": _check_id(path, line, fields[columns["object"]]), "type": kind, "vertex": vertex,
                      "pixels": pixels, "attribute": fields[columns["attribute"]] if "attribute" in columns else "",
                      "line": line})
    return picks


def write_control(path: str | Path, control: ControlPoints) -> None:
    """Write control points as ``id,X,Y,Z[,sX,sY,sZ]`` (metres, 6 decimals = micrometres), atomically."""
    handle = io.StringIO()
    writer = csv.writer(handle)
    header = list(CONTROL_COLUMNS) + (list(CONTROL_SIGMA_COLUMNS) if control.sigmas is not None else [])
    writer.writerow(header)
    for i, pid in enumerate(control.ids):
        row = [pid] + [f"{v:.6f}" for v in control.xyz[i]]
        if control.sigmas is not None:
            row += [f"{v:.6f}" for v in control.sigmas[i]]
        writer.writerow(row)
    write_text_atomic(path, handle.getvalue())


def write_observations(path: str | Path, observations: StereoObservations, with_pair: bool = True) -> None:
    """Write observations as ``id,xl,yl,xr,yr[,pair]`` (pixels, 4 decimals), atomically."""
    handle = io.StringIO()
    writer = csv.writer(handle)
    writer.writerow(list(OBSERVATION_COLUMNS) + (["pair"] if with_pair else []))
    for i, pid in enumerate(observations.ids):
        row = [pid] + [f"{v:.4f}" for v in (*observations.left[i], *observations.right[i])]
        if with_pair:
            row.append(observations.pairs[i])
        writer.writerow(row)
    write_text_atomic(path, handle.getvalue())


def refuse_outside_image(path: str | Path, labels: list[str], lines: list[int | None], left: np.ndarray,
                         right: np.ndarray, sizes: tuple[tuple[int | None, int | None], tuple[int | None, int | None]]
                         ) -> None:
    """An :class:`InputFileError` naming the file, line and point when a pixel lies outside its image.

    ``left``/``right``: (N, 2) pixels, x right and y down from the centre of the top-left pixel, so an image
    of ``width`` × ``height`` px spans −0.5 … width − 0.5 and −0.5 … height − 0.5; ``sizes``: (width,
    height) of the left and right images (None: not known, nothing checked). Such a pixel is a typing or
    unit error (say, millimetres or a normalised coordinate), named here rather than as a lens that
    cannot be inverted far outside its frame."""
    for side, pixels, size in (("left", left, sizes[0]), ("right", right, sizes[1])):
        pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        outside = outside_image(pixels, size)
        if outside.any():
            k = int(np.flatnonzero(outside)[0])
            raise outside_image_error(path, side, labels[k], lines[k] if k < len(lines) else None, pixels[k], size,
                                      int(outside.sum()))


def refuse_off_every_image(path: str | Path, labels: list[str], lines: list[int | None], left: np.ndarray,
                           right: np.ndarray) -> None:
    """An :class:`InputFileError` naming the file, line and point when a pixel lies left of or above every
    image (x or y below −0.5: pixels start at the centre of the top-left pixel), whatever the images' size:
    what can be checked of pixels whose image is not known yet (:func:`refuse_outside_image` when it is)."""
    for side, pixels in (("left", left), ("right", right)):
        pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        off = (pixels[:, 0] < -0.5) | (pixels[:, 1] < -0.5)
        if off.any():
            k = int(np.flatnonzero(off)[0])
            more = f"; {int(off.sum())} such pixels in all" if off.sum() > 1 else ""
            raise InputFileError(str(path), f"point {labels[k]!r}: the {side} pixel ({pixels[k, 0]:g}, "
                                 f"{pixels[k, 1]:g}) lies outside every image (x and y start at -0.5, the "
                                 f"top-left pixel's edge){more}", lines[k] if k < len(lines) else None)


def outside_image(pixels: np.ndarray, size: tuple[int | None, int | None]) -> np.ndarray:
    """Which of the (N, 2) ``pixels`` lie outside an image of ``size`` (width, height; None: not known,
    none is outside); see :func:`refuse_outside_image` for the convention."""
    width, height = size
    if width is None or height is None or len(pixels) == 0:
        return np.zeros(len(pixels), dtype=bool)
    return ((pixels[:, 0] < -0.5) | (pixels[:, 0] > width - 0.5) | (pixels[:, 1] < -0.5)
            | (pixels[:, 1] > height - 0.5))


def outside_image_error(path: str | Path, side: str, label: str, line: int | None, pixel, size: tuple[int, int],
                        count: int) -> InputFileError:
    """The error of point ``label``'s ``side`` pixel outside its image (the first of ``count`` such)."""
    (x, y), (width, height) = pixel, size
    more = f"; {count} such pixels in all" if count > 1 else ""
    return InputFileError(str(path), f"point {label!r}: the {side} pixel ({x:g}, {y:g}) lies outside the {side} "
                          f"image ({width} × {height} px: x from -0.5 to {width - 0.5:g}, y from -0.5 to "
                          f"{height - 0.5:g}){more}", line)
