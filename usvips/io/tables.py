"""Control and observation CSV files.

* Control: ``id,X,Y,Z[,sX,sY,sZ]`` — metres.
* Observations: ``id,xl,yl,xr,yr[,pair]`` — pixels (x right, y down, origin at the centre of the top-left
  pixel); any further numeric columns are kept (``extra``), e.g. the seeds' ``dX,dY,dZ``.

Lines starting with ``#`` and blank lines are ignored; the first other line is the header. Every error
names the file and the line.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.observations import ControlPoints, StereoObservations

CONTROL_COLUMNS = ("id", "X", "Y", "Z")
CONTROL_SIGMA_COLUMNS = ("sX", "sY", "sZ")
OBSERVATION_COLUMNS = ("id", "xl", "yl", "xr", "yr")


def _rows(path: Path) -> tuple[list[str], list[tuple[int, list[str]]]]:
    if not path.is_file():
        raise InputFileError(str(path), "no such file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise InputFileError(str(path), "not a text (UTF-8) CSV file") from None
    header: list[str] | None = None
    rows: list[tuple[int, list[str]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        # (a line without quotes splits as csv would, at a fraction of the cost of a reader per line)
        fields = [f.strip() for f in (stripped.split(",") if '"' not in stripped else next(csv.reader([stripped])))]
        if header is None:
            header = fields
            header_line = number
            continue
        rows.append((number, fields))
    if header is None:
        raise InputFileError(str(path), "the file has no header line")
    if len(set(header)) != len(header):
        raise InputFileError(str(path), f"duplicate column names in the header {header}", header_line)
    if not rows:
        raise InputFileError(str(path), "the file has a header but no data rows")
    return header, rows


def _column_index(path: Path, header: list[str], required: tuple[str, ...]) -> dict[str, int]:
    missing = [c for c in required if c not in header]
    if missing:
        raise InputFileError(str(path), f"missing column(s) {', '.join(missing)}; the header has "
                             f"{', '.join(header)} (expected {','.join(required)})")
    return {name: header.index(name) for name in header}


def _number(path: Path, line: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputFileError(str(path), f"column {column}: {text!r} is not a number", line) from None
    if not math.isfinite(value):
        raise InputFileError(str(path), f"column {column}: {text!r} is not a finite number", line)
    return value


def _check_width(path: Path, line: int, fields: list[str], header: list[str]) -> None:
    if len(fields) != len(header):
        raise InputFileError(str(path), f"{len(fields)} fields but the header has {len(header)}", line)


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
    ids, xyz, sig, lines = [], [], [], []
    first_line: dict[str, int] = {}
    for line, fields in rows:
        _check_width(path, line, fields, header)
        pid = _check_id(path, line, fields[columns["id"]])
        if pid in first_line:
            raise InputFileError(str(path), f"duplicate id {pid!r} (first on line {first_line[pid]})", line)
        first_line[pid] = line
        ids.append(pid)
        lines.append(line)
        xyz.append([_number(path, line, c, fields[columns[c]]) for c in ("X", "Y", "Z")])
        if has_sigma:
            values = [_number(path, line, c, fields[columns[c]]) for c in CONTROL_SIGMA_COLUMNS]
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
            raise InputFileError(str(path), f"duplicate id {pid!r} in pair {pair!r} "
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
        if np.all(np.isfinite(values)):
            return values
    except ValueError:
        pass
    return np.array([[_number(path, line, c, fields[columns[c]]) for c in names] for line, fields in rows])


def write_control(path: str | Path, control: ControlPoints) -> None:
    """Write control points as ``id,X,Y,Z[,sX,sY,sZ]`` (metres, 6 decimals = micrometres)."""
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        header = list(CONTROL_COLUMNS) + (list(CONTROL_SIGMA_COLUMNS) if control.sigmas is not None else [])
        writer.writerow(header)
        for i, pid in enumerate(control.ids):
            row = [pid] + [f"{v:.6f}" for v in control.xyz[i]]
            if control.sigmas is not None:
                row += [f"{v:.6f}" for v in control.sigmas[i]]
            writer.writerow(row)


def write_observations(path: str | Path, observations: StereoObservations, with_pair: bool = True) -> None:
    """Write observations as ``id,xl,yl,xr,yr[,pair]`` (pixels, 4 decimals)."""
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(list(OBSERVATION_COLUMNS) + (["pair"] if with_pair else []))
        for i, pid in enumerate(observations.ids):
            row = [pid] + [f"{v:.4f}" for v in (*observations.left[i], *observations.right[i])]
            if with_pair:
                row.append(observations.pairs[i])
            writer.writerow(row)
