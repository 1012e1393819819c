"""The double-read report as a CSV table (comma separated, one row per pair or unmatched object, the
agreement statistics as ``#`` comment lines above the header), written atomically (:mod:`usvips.io.atomic`)."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

from usvips.io.atomic import write_text_atomic
from usvips.io.export import cell


def double_read_csv(columns: Sequence[str], rows: Sequence[dict], summary: Sequence[str] = ()) -> str:
    """The table's text: ``summary`` lines as ``# …`` comments, the header ``columns``, then each row's
    values in that order (None as an empty cell, numbers unrounded, text sanitised by :func:`cell`)."""
    buffer = io.StringIO()
    for line in summary:
        buffer.write("# " + " ".join(str(line).split()) + "\n")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(list(columns))
    writer.writerows([["" if row.get(name) is None else cell(row[name]) for name in columns] for row in rows])
    return buffer.getvalue()


def write_double_read_csv(path: str | Path, columns: Sequence[str], rows: Sequence[dict],
                          summary: Sequence[str] = ()) -> None:
    """Write :func:`double_read_csv` to ``path`` atomically (the old file, if any, untouched on error)."""
    write_text_atomic(path, double_read_csv(columns, rows, summary))
