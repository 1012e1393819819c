"""The GlobalArchive-shaped export of a project: the campaign's metadata, count and length tables
(:mod:`usvips.io.globalarchive`) beside the EventMeasure-style tables CheckEM reads, all named by the
CampaignID, written in one folder all or nothing.

The objects and their figures are those of every other export (:func:`usvips.app.project_export.
collect_export`: one function computes each figure and its σ). A sample is a deployment's OpCode, or
``OpCode-Period`` for an object on a period of a video (as CheckEM names a DOV sample). The count of a
sample and taxon is its MaxN (:func:`usvips.core.abundance.max_n`): the individuals (the observation
record's number; 1 without a record) summed per frame, the largest sum; the lengths are every object of
a kind EventMeasure lists as a length (length, arc); a double-read survey is exported from one reader's
objects (``reader``). Refused, one line naming it, before anything is
written: a project without a campaign or with one missing a mandatory field, without deployment
metadata or with a deployment missing what GlobalArchive requires, or an object on a video that no
deployment covers.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from usvips.app.project_export import collect_export
from usvips.core.abundance import max_n
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import QualityRules
from usvips.core.measurements import kind as measurement_kind
from usvips.io.atomic import replacing, write_files_atomic
from usvips.io.export import eventmeasure_paths, eventmeasure_tables
from usvips.io.globalarchive import (
    archive_paths,
    check_campaign,
    check_samples,
    count_table,
    length_table,
    metadata_csv,
)
from usvips.store.interface import ProjectStore


def archive_targets(project: ProjectStore, folder: str | Path) -> list[Path]:
    """The files :func:`export_archive` writes into ``folder`` for the project's campaign (checked: a
    missing campaign or mandatory field is refused here already)."""
    campaign = check_campaign(project.campaign(), str(project.path))
    em = eventmeasure_paths(Path(folder) / f"{campaign.campaign_id}.em.txt")
    return list(dict.fromkeys([*em.values(), *archive_paths(folder, campaign.campaign_id).values()]))


def export_archive(project: ProjectStore, folder: str | Path, rules: QualityRules | None = None,
                   skipped: list[str] | None = None, reader: str | None = None,
                   warnings: list[str] | None = None) -> list[Path]:
    """Write the campaign's tables into ``folder`` (an existing folder): ``CAMPAIGNID_Metadata.csv``
    (CheckEM's sample columns and the campaign's), ``_Count.txt`` (MaxN), ``_Length.txt``, and the
    EventMeasure-style ``_Lengths.txt``, ``_3DPoints.txt`` (and tables of their own kinds); returns the
    files written. Objects without figures are left out and named in ``skipped``. ``reader``: only the
    objects this annotator made (a double-read survey, whose fish would otherwise be counted twice); a
    name who made none is refused by name; without ``reader``, objects of several annotators are counted
    together, and ``warnings`` says so (a team that split the videos counts right; a double-read survey
    would count its fish twice)."""
    where = str(project.path)
    folder = Path(folder)
    if not folder.is_dir():
        raise InvalidParameterError("folder", f"{folder}: not an existing folder (the GlobalArchive tables are "
                                    "written into a folder, named by the CampaignID)")
    campaign = check_campaign(project.campaign(), where)
    creators = Counter(o.creator for o in project.objects())
    if reader is not None and reader not in creators:
        raise InvalidParameterError("reader", f"{where}: annotator {reader!r} measured no object of this survey",
                                    label="reader")
    if reader is None and len(creators) > 1 and warnings is not None:
        made = ", ".join(f"{name or 'unnamed'} {count}" for name, count in creators.most_common())
        warnings.append(f"the objects of {len(creators)} annotators ({made}) are counted together: right when "
                        "they measured different fish, twice over when the survey was double-read (then export one "
                        "reader's objects)")
    content = collect_export(project, rules=rules, skipped=skipped, creator=reader)
    check_samples(content.samples, where)
    known = {deployment.opcode for deployment, _ in content.samples}
    counted_groups, frames, numbers, lengths = [], [], [], []
    for measured in content.objects:
        opcode = content.opcodes[measured.id]
        if opcode not in known:
            raise InvalidParameterError("deployment", f"{where}: object {measured.id} was measured where no "
                                        "deployment is stored (its video has none and the project has none): "
                                        "GlobalArchive needs its sample (usvips project set-metadata)")
        image = content.images.get(measured.id, ())
        period = image[5] if len(image) > 5 else ""
        sample = f"{opcode}-{period}" if period else opcode
        record = content.records.get(measured.id)
        taxon = ("", "", "") if record is None else (record.family, record.genus, record.species)
        number = 1 if record is None else record.number
        counted_groups.append((sample, *taxon))
        # one frame: the pair, or the video's chapter file and frame number in it
        frames.append((content.places[measured.id][0], *image[:2]) if image else ("object", measured.id))
        numbers.append(number)
        if measurement_kind(measured.kind).eventmeasure == "Lengths":
            lengths.append((sample, *taxon, "" if record is None else record.code, number, measured.main.value,
                            measured.main.sigma, measured.id))
    tables = eventmeasure_tables(content.objects, **content.eventmeasure())
    files = {target: tables[table] for table, target in eventmeasure_paths(folder / f"{campaign.campaign_id}.em.txt")
             .items()}
    paths = archive_paths(folder, campaign.campaign_id)
    files[paths["Metadata"]] = metadata_csv(campaign, content.samples)  # CheckEM's, with the campaign's columns
    files[paths["Count"]] = count_table(campaign, max_n(counted_groups, frames, numbers))
    files[paths["Length"]] = length_table(campaign, lengths)
    write_files_atomic(files)
    return list(files)


def export_archive_folder(project: ProjectStore, folder: str | Path, local: str | None = None,
                          replace: bool = False, reader: str | None = None,
                          skipped: list[str] | None = None, warnings: list[str] | None = None) -> list[Path]:
    """:func:`export_archive` into ``folder``, made when it does not exist (its parent must) and removed
    again when the export is refused: all or nothing. Existing tables are replaced only with ``replace``
    (kept as NAME.bak), never when one is ``local`` (the project file) — the rule of every output."""
    folder = Path(folder)
    targets = archive_targets(project, folder)
    made = not folder.exists()
    if made:
        if not folder.parent.is_dir():
            raise InvalidParameterError("folder", f"{folder}: the folder {folder.parent} does not exist")
        folder.mkdir()
    try:
        with replacing(targets, project=local, replace=replace):
            return export_archive(project, folder, skipped=skipped, reader=reader, warnings=warnings)
    except BaseException:
        if made and not any(folder.iterdir()):
            folder.rmdir()
        raise
