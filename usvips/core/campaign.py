"""A survey's campaign in GlobalArchive's terms: the discrete set of samples (deployments) taken with one
sampling and image-analysis method, named by its CampaignID, within a Project. Plain values, validated;
stored by the project (as JSON), written out by io (:mod:`usvips.io.globalarchive`).

GlobalArchive (globalarchivemanual.github.io, "Definitions" and "Creating the Metadata file"): a Project
holds Campaigns; a CampaignID has the form ``YYYY-MM_Project.name_Method`` and starts the name of every
file uploaded for it (``$_Metadata.csv``, ``$_Count.txt``, ``$_Length.txt``); the Method is the sampling
method (e.g. stereo-BRUVs, stereo-DOVs). A campaign may be stored half filled in; what an export needs
(:data:`MANDATORY`) is checked by :meth:`Campaign.missing` when exporting.

Conventions: dates as ``YYYY-MM-DD``; every text one line without tabs (the tables are tab separated).
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import asdict, dataclass, fields

from usvips.core.errors import InvalidParameterError

#: Sampling methods GlobalArchive's examples and CheckEM name (any other text is accepted too)
METHODS = ("stereo-BRUVs", "stereo-DOVs", "stereo-ROV", "stereo-BOSS", "stereo-towed-video", "UVC")

#: What a GlobalArchive export cannot do without
MANDATORY = ("campaign_id", "project", "method", "submitter")

#: A CampaignID starts file names: letters, digits and . _ - only
_CAMPAIGN_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")


def _text(name: str, value: object) -> str:
    text = "" if value is None else str(value).strip()
    if any(c in text for c in "\t\n\r") or any(ord(c) < 32 for c in text):
        raise InvalidParameterError(name, "must be one line without tabs (the exported tables are tab separated)")
    return text


@dataclass(frozen=True)
class Campaign:
    """The campaign a project's deployments belong to: ``campaign_id`` (GlobalArchive's CampaignID, e.g.
    ``2024-03_Abrolhos_stereo-BRUVs``; letters, digits, ``.``, ``_``, ``-``), ``project`` (GlobalArchive's
    Project), ``method`` (sampling method, e.g. stereo-BRUVs, :data:`METHODS`), ``sampling_design`` (e.g.
    "stratified random, 4 strata"), ``submitter`` (who uploads it) and ``institution``, ``start_date`` and
    ``end_date`` (YYYY-MM-DD, end not before start), ``image_analysis`` (how the imagery was annotated;
    default USVIPS) and a ``comment``. Empty texts are allowed here (:meth:`missing` names what an
    export needs)."""

    campaign_id: str = ""
    project: str = ""
    method: str = ""
    sampling_design: str = ""
    submitter: str = ""
    institution: str = ""
    start_date: str = ""
    end_date: str = ""
    image_analysis: str = "USVIPS"
    comment: str = ""

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, _text(f.name, getattr(self, f.name)))
        if self.campaign_id and not _CAMPAIGN_ID.fullmatch(self.campaign_id):
            raise InvalidParameterError("campaign_id", "starts the exported file names: letters, digits, '.', '_' "
                                        f"and '-' only (GlobalArchive: YYYY-MM_Project.name_Method), got "
                                        f"{self.campaign_id[:60]!r}")
        dated = re.match(r"(\d{4})-(\d{2})_", self.campaign_id)
        if dated and not 1 <= int(dated.group(2)) <= 12:  # GlobalArchive's YYYY-MM: a month that is none
            raise InvalidParameterError("campaign_id", f"{self.campaign_id[:60]!r} starts with the month "
                                        f"{dated.group(2)}, which is none (GlobalArchive: YYYY-MM_Project.name_Method)")
        dates = {}
        for name in ("start_date", "end_date"):
            value = getattr(self, name)
            if value:
                try:
                    dates[name] = _dt.date.fromisoformat(value)
                except ValueError:
                    raise InvalidParameterError(name, f"must be a date YYYY-MM-DD, got {value[:40]!r}") from None
                if len(value) != 10:
                    raise InvalidParameterError(name, f"must be a date YYYY-MM-DD, got {value[:40]!r}")
        if len(dates) == 2 and dates["end_date"] < dates["start_date"]:
            raise InvalidParameterError("end_date", f"{self.end_date} is before the start date {self.start_date}")

    def missing(self) -> list[str]:
        """The fields of :data:`MANDATORY` left empty, in that order."""
        return [name for name in MANDATORY if not getattr(self, name)]

    def to_dict(self) -> dict[str, str]:
        """The fields by name (JSON-ready)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> Campaign:
        """A campaign from :meth:`to_dict`'s form; an unknown field is an :class:`InvalidParameterError`."""
        if not isinstance(data, dict):
            raise InvalidParameterError("campaign", f"must be a mapping of fields, got {type(data).__name__}")
        unknown = sorted(set(data) - set(CAMPAIGN_FIELDS))
        if unknown:
            raise InvalidParameterError("campaign", f"unknown field(s) {', '.join(unknown)}")
        return cls(**data)


#: Field names of :class:`Campaign` in order (the stored JSON's keys and the command line's options).
CAMPAIGN_FIELDS = tuple(f.name for f in fields(Campaign))
