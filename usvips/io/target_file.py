"""Calibration-target files: a target's description as versioned JSON, and a printable PDF of a board.

Layout (version 1; lengths in metres)::

    {"format": "usvips-target", "version": 1, "kind": "chessboard", "cols": 9, "rows": 6, "square": 0.024}

the fields after ``kind`` being the kind's own (:mod:`usvips.core.calibration_targets.kinds`). A file of a
newer version is refused by name; every error is one line naming the file and the field.

The printable PDF (:func:`write_printable`) draws the board at true scale — 1 mm of board is 1 mm of
paper — on a page large enough for the sheet (at least A4), with a 100 mm scale bar, the description and
the size a marked square must measure printed in the margin, and checks the drawn size before writing.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from usvips.core.calibration_targets import CalibrationTarget, from_description
from usvips.core.errors import InputFileError
from usvips.io.atomic import write_bytes_atomic, write_text_atomic
from usvips.io.text_lines import not_utf8

FORMAT = "usvips-target"
VERSION = 1
#: The largest target file read (bytes): a description is small; a 3-D field of thousands of targets fits.
MAX_BYTES = 20_000_000

MM = 1e-3
POINTS_PER_METRE = 72 / 0.0254
A4 = (0.210, 0.297)
MARGIN = 0.015
BAND = 0.030  # the band below the sheet for the scale bar and the text (metres)


def target_to_dict(target: CalibrationTarget) -> dict:
    """The file's JSON object for ``target``."""
    return {"format": FORMAT, "version": VERSION, **target.describe()}


def target_from_dict(data: object, path: str = "<target>") -> CalibrationTarget:
    """A target from a file's JSON object; errors name ``path`` and the field."""
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputFileError(path, f"not a USVIPS target file (\"format\" must be {FORMAT!r})")
    version = data.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise InputFileError(path, f"field 'version': must be a whole number from 1, got {version!r}")
    if version > VERSION:
        raise InputFileError(path, f"field 'version': target file version {version} is newer than this USVIPS "
                             f"reads ({VERSION}); update USVIPS")
    description = {key: value for key, value in data.items() if key not in ("format", "version")}
    if not isinstance(description.get("kind"), str):
        raise InputFileError(path, "field 'kind': missing (the target's kind, e.g. \"chessboard\")")
    from usvips.core.calibration_targets import names

    if description["kind"] not in names():
        raise InputFileError(path, f"field 'kind': unknown target kind {description['kind']!r}; known: "
                             f"{', '.join(names())}")
    return from_description(description, source=path)


def read_target(path: str | Path) -> CalibrationTarget:
    """Read a target file."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_BYTES:
            raise InputFileError(str(path), f"larger than {MAX_BYTES // 1_000_000} MB: not a target description")
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputFileError(str(path), "no such file") from None
    except IsADirectoryError:
        raise InputFileError(str(path), "is a folder, not a target file") from None
    except UnicodeDecodeError as error:
        raise not_utf8(str(path), error.object, error.start, "target file (JSON)") from None
    except OSError as error:
        raise InputFileError(str(path), f"cannot read: {error.strerror or error}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise InputFileError(str(path), f"not valid JSON: {error.msg}", error.lineno) from None
    except RecursionError:
        raise InputFileError(str(path), "nested too deeply") from None
    return target_from_dict(data, str(path))


def write_target(path: str | Path, target: CalibrationTarget) -> None:
    """Write ``target``'s description (atomically: a failure leaves no partial file)."""
    write_text_atomic(path, json.dumps(target_to_dict(target), indent=1) + "\n")


# ----------------------------------------------------------------------------------------- printing
def page_size(target: CalibrationTarget) -> tuple[float, float]:
    """The page (width, height) in metres: the sheet, a margin round it and a band below, at least A4 in
    the orientation of the sheet."""
    x0, y0, x1, y1 = target.sheet()
    width, height = (x1 - x0) + 2 * MARGIN, (y1 - y0) + 2 * MARGIN + BAND
    small, large = sorted(A4)
    floor = (large, small) if width > height else (small, large)
    return max(width, floor[0]), max(height, floor[1])


def _label(target: CalibrationTarget) -> str:
    description = target.describe()
    fields = ", ".join(f"{key} {value * 1000:g} mm" if isinstance(value, float) else f"{key} {value}"
                       for key, value in description.items() if key != "kind")
    return f"USVIPS calibration target: {description['kind']} ({fields})"


def _check_length(target: CalibrationTarget) -> tuple[str, float, tuple[float, float, float, float]]:
    """What the printed-size check measures: a name, its true length (m) and where it is (board frame)."""
    rectangles, circles = target.shapes()
    if len(rectangles):
        first = rectangles[np.argmax(rectangles[:, 2] - rectangles[:, 0])]
        return "the widest black square", float(first[2] - first[0]), tuple(first)
    x, y, r = circles[0]
    return "the first circle's diameter", float(2 * r), (x - r, y - r, x + r, y + r)


def write_printable(path: str | Path, target: CalibrationTarget) -> tuple[float, float]:
    """Write a PDF of a printed board at true scale; returns the page size (width, height) in metres.

    The board is one filled path (rectangles and circles, no snapping or simplification), placed so that a
    board metre is a paper metre; after drawing, the drawn width of a marked square is measured in PDF
    points and must equal its size (to 1e-6): a mistake here would silently scale every calibration."""
    from matplotlib import rc_context
    from matplotlib.backends.backend_pdf import FigureCanvasPdf
    from matplotlib.figure import Figure
    from matplotlib.patches import PathPatch, Rectangle
    from matplotlib.path import Path as MplPath

    if not hasattr(target, "shapes"):
        raise InputFileError(str(path), f"a {target.kind} target is not a printed board; nothing to print")
    if Path(path).suffix.lower() != ".pdf":
        raise InputFileError(str(path), "the printable board is a PDF: give a name ending in .pdf")
    x0, y0, x1, y1 = target.sheet()
    page_w, page_h = page_size(target)
    sheet_w, sheet_h = x1 - x0, y1 - y0
    left = (page_w - sheet_w) / 2
    bottom = MARGIN + BAND
    with rc_context({"path.simplify": False, "pdf.compression": 6, "pdf.fonttype": 42}):
        figure = Figure(figsize=(page_w / 0.0254, page_h / 0.0254), dpi=72)
        FigureCanvasPdf(figure)
        axes = figure.add_axes((left / page_w, bottom / page_h, sheet_w / page_w, sheet_h / page_h))
        axes.set_xlim(x0, x1)
        axes.set_ylim(y1, y0)  # the board's y runs down the sheet
        axes.set_axis_off()
        rectangles, circles = target.shapes()
        vertices, codes = [], []
        for a, b, c, d in rectangles:
            vertices += [(a, b), (c, b), (c, d), (a, d), (a, b)]
            codes += [MplPath.MOVETO, MplPath.LINETO, MplPath.LINETO, MplPath.LINETO, MplPath.CLOSEPOLY]
        for cx, cy, r in circles:
            unit = MplPath.circle((cx, cy), r)
            vertices += list(map(tuple, unit.vertices))
            codes += list(unit.codes)
        patch = PathPatch(MplPath(vertices, codes), facecolor="black", edgecolor="none", linewidth=0,
                          antialiased=False)
        patch.set_snap(False)
        axes.add_patch(patch)
        axes.add_patch(Rectangle((x0, y0), sheet_w, sheet_h, fill=False, edgecolor="0.75", linewidth=0.5,
                                 linestyle=(0, (4, 4))))
        # the 100 mm scale bar (50 mm on a narrow page), millimetres at true scale, ticks every 10 mm
        bar = 0.1 if page_w - 2 * MARGIN >= 0.12 else 0.05
        scale = figure.add_axes((MARGIN / page_w, MARGIN / page_h, bar / page_w, 0.004 / page_h))
        scale.set_xlim(0, bar * 1000)
        scale.set_ylim(0, 1)
        scale.set_axis_off()
        for k in range(int(round(bar * 100))):
            scale.add_patch(Rectangle((10 * k, 0), 10, 1, facecolor="black" if k % 2 == 0 else "white",
                                      edgecolor="black", linewidth=0.3))
        what, size, where = _check_length(target)
        lines = (_label(target),
                 f"Print at 100 % (not \"fit to page\"), then measure: the bar must be {bar * 1000:g} mm and "
                 f"{what} {size * 1000:.2f} mm.",
                 f"Glue it flat on a rigid board. Page {page_w * 1000:.0f} × {page_h * 1000:.0f} mm.")
        figure.text((MARGIN + bar + 0.004) / page_w, MARGIN / page_h, f"{bar * 1000:g} mm", fontsize=6.5)
        for k, line in enumerate(lines):
            figure.text(MARGIN / page_w, (MARGIN + 0.022 - 0.0055 * k) / page_h, line, fontsize=6.5)
        drawn = axes.transData.transform([[where[0], where[1]], [where[2], where[1]]])
        drawn_points = float(abs(drawn[1, 0] - drawn[0, 0]))
        if abs(drawn_points - size * POINTS_PER_METRE) > 1e-6 * size * POINTS_PER_METRE:
            raise InputFileError(str(path), f"internal check failed: {what} would print {drawn_points / 72 * 25.4:.4f} "
                                 f"mm, not {size * 1000:.4f} mm; nothing written")
        buffer = io.BytesIO()
        figure.savefig(buffer, format="pdf", dpi=72)
    write_bytes_atomic(path, buffer.getvalue())
    return page_w, page_h
