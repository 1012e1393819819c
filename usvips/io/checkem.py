"""CheckEM's sample metadata: ``NAME_Metadata.csv`` beside the EventMeasure-style tables ``NAME_Lengths.txt``
and ``NAME_3DPoints.txt`` (:mod:`usvips.io.export`), one row per sample.

CheckEM (GlobalArchiveManual/CheckEM, ``R/read_metadata.R``) reads every ``*_Metadata.csv`` of a folder
as text, takes the campaign from the file name (before ``_Metadata.csv``), cleans the column names
(``clean_names``: trimmed, R's ``make.names``, dots to ``_``, lower case) and renames the GlobalArchive
names: Latitude → latitude_dd, Longitude → longitude_dd, Depth → depth_m, Successful.count →
successful_count, Successful.length → successful_length. The sample is the OpCode for BRUVs and
``OpCode-Period`` for DOVs (as it is for the lengths), so a deployment measured in periods (transects)
gets a row per period. Without a ``date_time`` column CheckEM builds one from Date (``YYYYMMDD``) and
Time (``HH:MM:SS``) and the time zone of the position, so Date is written in that form.

Comma separated with the :mod:`csv` module, cells sanitised (:func:`usvips.io.export.cell`).
"""

from __future__ import annotations

from collections.abc import Sequence

from usvips.core.deployment import Deployment

METADATA_COLUMNS = ["OpCode", "Period", "Sample", "Date", "Time", "Latitude", "Longitude", "Depth", "Site",
                    "Location", "Status", "Successful.count", "Successful.length", "Observer", "Comment"]


def _yes(flag: bool) -> str:
    return "Yes" if flag else "No"


def metadata_row(deployment: Deployment, period: str = "") -> list:
    """One ``_Metadata.csv`` row (:data:`METADATA_COLUMNS`) of a deployment, or of one of its periods
    (the sample is then ``OpCode-Period``, as CheckEM names a DOV sample)."""
    def optional(value: float | None) -> object:
        return "" if value is None else value

    return [deployment.opcode, period, f"{deployment.opcode}-{period}" if period else deployment.opcode,
            deployment.date.replace("-", ""), deployment.clock, optional(deployment.latitude),
            optional(deployment.longitude), optional(deployment.depth_m), deployment.site, deployment.location,
            deployment.status, _yes(deployment.successful_count), _yes(deployment.successful_length),
            deployment.observer, deployment.comment]


def metadata_rows(samples: Sequence[tuple[Deployment, str]]) -> list[list]:
    """Rows of (deployment, period) samples, each sample once, in the order given."""
    rows, seen = [], set()
    for deployment, period in samples:
        if (deployment.opcode, period) not in seen:
            seen.add((deployment.opcode, period))
            rows.append(metadata_row(deployment, period))
    return rows
