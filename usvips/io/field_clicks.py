"""Clicks file of a target field: the targets a user identified in the two images of a pair.

``side,id,x,y`` — ``side`` is ``left`` or ``right``, ``id`` a control point's id, ``x, y`` pixels (x right,
y down, origin at the centre of the top-left pixel). Lines starting with ``#`` and blank lines are
ignored; the first other line is the header; further columns are ignored. Example::

    side,id,x,y
    left,T01,412.5,233.0
    left,T07,980.2,241.7
    right,T01,300.1,230.4

Every error names the file and the line.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path

from usvips.core.errors import InputFileError
from usvips.io.atomic import write_text_atomic
from usvips.io.tables import _check_id, _check_width, _column_index, _number, _rows, _show

CLICK_COLUMNS = ("side", "id", "x", "y")
SIDES = ("left", "right")


@dataclass(frozen=True)
class FieldClicks:
    """``pixels[side][id]`` = (x, y) pixels of each identified target; ``lines[(side, id)]`` its line in
    ``source`` (for messages)."""

    pixels: dict[str, dict[str, tuple[float, float]]]
    source: str = ""
    lines: dict[tuple[str, str], int] = field(default_factory=dict)


def read_clicks(path: str | Path) -> FieldClicks:
    """Read a clicks file; raises :class:`InputFileError` naming the file and line."""
    path = Path(path)
    header, rows = _rows(path)
    columns = _column_index(path, header, CLICK_COLUMNS)
    pixels: dict[str, dict[str, tuple[float, float]]] = {side: {} for side in SIDES}
    lines: dict[tuple[str, str], int] = {}
    for line, fields in rows:
        _check_width(path, line, fields, header)
        side = fields[columns["side"]].lower()
        if side not in SIDES:
            raise InputFileError(str(path), f"side {_show(fields[columns['side']])} is neither left nor right", line)
        pid = _check_id(path, line, fields[columns["id"]])
        if (side, pid) in lines:
            raise InputFileError(str(path), f"target {_show(pid)} is identified twice in the {side} image (first on "
                                 f"line {lines[(side, pid)]})", line)
        lines[(side, pid)] = line
        pixels[side][pid] = (_number(path, line, "x", fields[columns["x"]]),
                             _number(path, line, "y", fields[columns["y"]]))
    return FieldClicks(pixels, str(path), lines)


def write_clicks(path: str | Path, pixels: dict[str, dict[str, tuple[float, float]]]) -> None:
    """Write identified targets as ``side,id,x,y`` (pixels, 2 decimals), atomically."""
    handle = io.StringIO()
    writer = csv.writer(handle, lineterminator="\n")
    writer.writerow(CLICK_COLUMNS)
    for side in SIDES:
        writer.writerows([side, pid, f"{x:.2f}", f"{y:.2f}"] for pid, (x, y) in pixels.get(side, {}).items())
    write_text_atomic(path, handle.getvalue())
