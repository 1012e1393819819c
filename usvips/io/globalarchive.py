"""GlobalArchive-shaped tables of a campaign: ``$_Metadata.csv`` (one row per sample, with the campaign's
identifiers and method metadata beside CheckEM's sample columns), and the generic ``$_Count.txt`` (MaxN
per sample and taxon) and ``$_Length.txt`` (one row per measured length), ``$`` being the CampaignID.

The format is GlobalArchive's (globalarchivemanual.github.io: "Creating the Metadata file", "Generating
generic count, length and mass data"): every file name starts with the CampaignID; the metadata is comma
separated with the required columns Sample, Latitude, Longitude (decimal degrees), Date (YYYYMMDD), Time
(hh:mm:ss), Depth, Successful.count and Successful.length (Yes/No), further columns allowed; Count and
Length are tab-separated text with Sample, Family, Genus, Species, Count (and Length, mm), further
columns allowed; Sample must equal the OpCode (or OpCode-Period) of the annotation tables exactly. The
metadata file is also CheckEM's (:mod:`usvips.io.checkem`; it reads any extra columns), so it replaces
the plain one in the EventMeasure-style set written beside it. A taxon left unidentified is written as
``Unknown`` (GlobalArchive refuses blank Family, Genus and Species in a count).

Cells sanitised by :func:`usvips.io.export.cell` (a number that is not finite — unknown — is an empty cell,
never "nan"; a mandatory one is refused by name); lengths and their precision (σ) in millimetres.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

from usvips.core.campaign import Campaign
from usvips.core.deployment import Deployment
from usvips.core.errors import InvalidParameterError
from usvips.io.checkem import METADATA_COLUMNS, metadata_rows
from usvips.io.export import cell, mandatory_number

#: the campaign's columns, after CheckEM's sample columns in the metadata and first in Count and Length
CAMPAIGN_COLUMNS = ["CampaignID", "Project", "Method", "Sampling.design", "Submitter", "Institution",
                    "Campaign.start", "Campaign.end", "Image.analysis", "Campaign.comment"]
COUNT_COLUMNS = ["CampaignID", "Sample", "Family", "Genus", "Species", "Count"]
LENGTH_COLUMNS = ["CampaignID", "Sample", "Family", "Genus", "Species", "Count", "Length", "Precision", "Code",
                  "ObjectID"]
UNKNOWN = "Unknown"

#: a deployment's fields GlobalArchive requires in the metadata
_REQUIRED_SAMPLE = ("date", "time", "latitude", "longitude", "depth_m")


def archive_paths(folder: str | Path, campaign_id: str) -> dict[str, Path]:
    """Table name → file in ``folder``: ``CAMPAIGNID_Metadata.csv``, ``_Count.txt``, ``_Length.txt``."""
    folder = Path(folder)
    return {"Metadata": folder / f"{campaign_id}_Metadata.csv", "Count": folder / f"{campaign_id}_Count.txt",
            "Length": folder / f"{campaign_id}_Length.txt"}


def check_campaign(campaign: Campaign | None, where: str) -> Campaign:
    """The campaign, or one line naming what GlobalArchive needs and is missing (``where``: the project)."""
    if campaign is None:
        raise InvalidParameterError("campaign", f"{where} has no campaign: set its CampaignID, project, method "
                                    "and submitter first (usvips project set-campaign, or the window's File › "
                                    "Deployment and georeference…)")
    missing = campaign.missing()
    if missing:
        raise InvalidParameterError("campaign", f"{where}: the campaign's {', '.join(missing)} "
                                    f"{'is' if len(missing) == 1 else 'are'} needed by GlobalArchive "
                                    "(usvips project set-campaign, or the window's File › Deployment and "
                                    "georeference…)")
    return campaign


def check_samples(samples: Sequence[tuple[Deployment, str]], where: str) -> None:
    """Every sample's deployment has what GlobalArchive's metadata requires; else one line naming the
    deployment (OpCode), the field and the option that sets it. No sample at all is an error too."""
    if not samples:
        raise InvalidParameterError("deployment", f"{where} has no deployment metadata: GlobalArchive needs each "
                                    "sample's OpCode, date, time, position and depth (usvips project set-metadata)")
    for deployment, _ in samples:
        missing = [name for name in _REQUIRED_SAMPLE if getattr(deployment, name) in (None, "")]
        if missing:
            names = ", ".join(name.removesuffix("_m") for name in missing)
            raise InvalidParameterError("deployment", f"{where}: deployment {deployment.opcode!r} has no {names}, "
                                        "which GlobalArchive requires (usvips project set-metadata, or the "
                                        "window's File › Deployment and georeference…)")


def _campaign_cells(campaign: Campaign) -> list[str]:
    c = campaign
    return [c.campaign_id, c.project, c.method, c.sampling_design, c.submitter, c.institution,
            c.start_date.replace("-", ""), c.end_date.replace("-", ""), c.image_analysis, c.comment]


def _csv(header: list[str], rows: list[list], dialect: str) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, dialect=dialect, lineterminator="\n")
    writer.writerow(header)
    flatten = dialect == "excel-tab"
    writer.writerows([[cell(v, flatten) if v != "" else "" for v in row] for row in rows])
    return buffer.getvalue()


def metadata_csv(campaign: Campaign, samples: Sequence[tuple[Deployment, str]]) -> str:
    """``$_Metadata.csv``: CheckEM's sample columns (:data:`~usvips.io.checkem.METADATA_COLUMNS`), then the
    campaign's (:data:`CAMPAIGN_COLUMNS`), one row per (deployment, period) sample."""
    extra = _campaign_cells(campaign)
    return _csv(METADATA_COLUMNS + CAMPAIGN_COLUMNS, [row + extra for row in metadata_rows(samples)], "excel")


def _taxon(family: str, genus: str, species: str) -> list[str]:
    return [family or UNKNOWN, genus or UNKNOWN, species or (UNKNOWN if not genus else "spp")]


def count_table(campaign: Campaign, counts: dict[tuple[str, str, str, str], int]) -> str:
    """``$_Count.txt``: (sample, family, genus, species) → MaxN, one row each, tab separated."""
    rows = [[campaign.campaign_id, sample, *_taxon(family, genus, species), count]
            for (sample, family, genus, species), count in counts.items()]
    return _csv(COUNT_COLUMNS, rows, "excel-tab")


def length_table(campaign: Campaign, lengths: Sequence[tuple[str, str, str, str, str, int, float, float, str]]) -> str:
    """``$_Length.txt``: one row per measured length — (sample, family, genus, species, code, number,
    length m, σ m, object id) — with Length and Precision in mm, tab separated. A length that is not a finite
    number is refused, naming its object (GlobalArchive requires Length); a σ that is not (unknown) is an
    empty Precision, never the text "nan"."""
    rows = [[campaign.campaign_id, sample, *_taxon(family, genus, species), number,
             mandatory_number(length, "Length", object_id, "GlobalArchive Length") * 1000, sigma * 1000,
             code, object_id] for sample, family, genus, species, code, number, length, sigma, object_id in lengths]
    return _csv(LENGTH_COLUMNS, rows, "excel-tab")
