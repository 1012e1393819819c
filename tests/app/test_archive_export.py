"""The GlobalArchive-shaped export: campaign and deployment columns in the metadata, MaxN counts and
lengths by sample and taxon (against counts made by hand over random surveys), the EventMeasure-style
tables beside them, all named by the CampaignID; refusals name the missing field and write nothing."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from usvips.app.archive_export import archive_targets, export_archive
from usvips.app.project_figures import measure_stored
from usvips.core.campaign import Campaign
from usvips.core.deployment import Deployment
from usvips.core.errors import InvalidParameterError
from usvips.core.observation_record import ObservationRecord
from usvips.store.opening import create_project
from usvips.store.records import Vertex

CAMPAIGN = Campaign("2024-03_Reef_stereo-BRUVs", "Reef monitoring", "stereo-BRUVs", "stratified random", "Ana Ng",
                    "UWA", "2024-03-01", "2024-03-09")
DEPLOYMENT = Deployment("OP1", "2024-03-02", "09:10", -28.7, 113.8, 22.0, site="north")
TAXA = [("Sparidae", "Pagrus", "auratus"), ("Labridae", "Coris", "auricularis"), ("", "", "")]


def _vertices(rng, pair, kind):
    start = rng.uniform(-1, 1, 3) + [0, 0, 3]
    ends = [start] if kind == "point" else [start, start + rng.uniform(0.1, 0.5) * np.array([1.0, 0, 0])]
    return [Vertex(0, 0, 0, 0, tuple(map(float, p)), np.eye(3) * 1e-6, None, pair) for p in ends]


def _random_survey(project, rng):
    """Objects on 4 pairs, random taxa (or none) and numbers; returns the MaxN expected per taxon."""
    pairs = [f"p{i}" for i in range(4)]
    for label in pairs:
        project.add_pair(label)
    per_frame: dict[tuple, dict[str, int]] = {}
    for _ in range(int(rng.integers(5, 40))):
        pair = str(rng.choice(pairs))
        kind = "point" if rng.uniform() < 0.3 else "length"
        (object_id,) = project.add_objects([(kind, _vertices(rng, pair, kind), "", "", "")])
        taxon = TAXA[int(rng.integers(0, len(TAXA)))]
        number = 1
        if taxon[1] or rng.uniform() < 0.5:  # some unidentified objects have a record, some none
            number = int(rng.integers(1, 4))
            project.set_record(object_id, ObservationRecord(*taxon, number=number))
        per_frame.setdefault(taxon, {}).setdefault(pair, 0)
        per_frame[taxon][pair] += number
    return {taxon: max(counts.values()) for taxon, counts in per_frame.items()}


def _table(path, delimiter):
    with open(path, newline="", encoding="utf-8") as stream:
        return list(csv.DictReader(stream, delimiter=delimiter))


def test_counts_are_maxn_and_lengths_the_figures_of_every_export_over_random_surveys(tmp_path):
    rng = np.random.default_rng(9)
    for trial in range(8):
        folder = tmp_path / f"out{trial}"
        folder.mkdir()
        project = create_project(tmp_path / f"s{trial}.usvips")
        try:
            expected = _random_survey(project, rng)
            project.set_campaign(CAMPAIGN)
            project.set_deployment(DEPLOYMENT)
            written = export_archive(project, folder)
            assert sorted(written) == sorted(archive_targets(project, folder))
            assert {p.name for p in written} >= {f"{CAMPAIGN.campaign_id}_{n}" for n in (
                "Metadata.csv", "Count.txt", "Length.txt", "Lengths.txt", "3DPoints.txt")}
            counts = _table(folder / f"{CAMPAIGN.campaign_id}_Count.txt", "\t")
            got = {(r["Family"], r["Genus"], r["Species"]): int(r["Count"]) for r in counts}
            unknown = {("", "", ""): ("Unknown", "Unknown", "Unknown")}
            assert got == {unknown.get(t, t): n for t, n in expected.items()}
            assert {r["Sample"] for r in counts} == {"OP1"} and {r["CampaignID"] for r in counts} == {
                CAMPAIGN.campaign_id}
            lengths = _table(folder / f"{CAMPAIGN.campaign_id}_Length.txt", "\t")
            stored = {o.id: o for o in project.objects()}
            assert sorted(int(r["ObjectID"]) for r in lengths) == sorted(i for i, o in stored.items()
                                                                         if o.kind == "length")
            for row in lengths:
                figure = measure_stored(project, stored[int(row["ObjectID"])]).main
                assert (float(row["Length"]), float(row["Precision"])) == (figure.value * 1000, figure.sigma * 1000)
            (meta,) = _table(folder / f"{CAMPAIGN.campaign_id}_Metadata.csv", ",")
            assert (meta["Sample"], meta["Date"], meta["Time"], meta["Latitude"], meta["Depth"]) == (
                "OP1", "20240302", "09:10:00", "-28.7", "22.0")
            assert (meta["CampaignID"], meta["Project"], meta["Method"], meta["Submitter"], meta["Campaign.start"]) == (
                CAMPAIGN.campaign_id, "Reef monitoring", "stereo-BRUVs", "Ana Ng", "20240301")
        finally:
            project.close()


@pytest.mark.parametrize(("setup", "words"), [
    (lambda p: None, "has no campaign"),
    (lambda p: p.set_campaign(Campaign("2024-03_x_stereo-BRUVs", method="stereo-BRUVs")),
     "the campaign's project, submitter are needed"),
    (lambda p: p.set_campaign(CAMPAIGN), "has no deployment metadata"),
    (lambda p: (p.set_campaign(CAMPAIGN), p.set_deployment(Deployment("OP7", "2024-03-02", "09:10", depth_m=3.0))),
     "deployment 'OP7' has no latitude, longitude"),
])
def test_what_is_missing_is_named_and_nothing_is_written(tmp_path, setup, words):
    project = create_project(tmp_path / "s.usvips")
    try:
        _random_survey(project, np.random.default_rng(1))
        setup(project)
        folder = tmp_path / "out"
        folder.mkdir()
        with pytest.raises(InvalidParameterError, match=words):
            export_archive(project, folder)
        assert list(folder.iterdir()) == []
    finally:
        project.close()


def test_an_object_no_deployment_covers_is_named(tmp_path):
    project = create_project(tmp_path / "s.usvips")
    try:
        folder = tmp_path / "videos"
        folder.mkdir()
        (folder / "v0.mp4").write_bytes(b"video")
        project.add_video("dive", [(folder / "v0.mp4", 10, 25.0)], [(folder / "v0.mp4", 10, 25.0)], 25.0, 10, (64, 48))
        project.add_video("other", [(folder / "v0.mp4", 10, 25.0)], [(folder / "v0.mp4", 10, 25.0)], 25.0, 10,
                          (64, 48))
        project.set_campaign(CAMPAIGN)
        project.set_deployment(DEPLOYMENT, "dive")  # the video 'other' and the project have none
        vertices = [Vertex(0, 0, 0, 0, (0.0, 0.0, 3.0), np.eye(3) * 1e-6, None, None, "other", 3, 3, 0.12)]
        (object_id,) = project.add_objects([("point", vertices, "", "", "")])
        with pytest.raises(InvalidParameterError, match=f"object {object_id} was measured where no deployment"):
            export_archive(project, folder)
    finally:
        project.close()


def test_a_double_read_survey_is_counted_from_one_readers_objects(tmp_path):
    project = create_project(tmp_path / "s.usvips")
    try:
        project.add_pair("p1")
        rng = np.random.default_rng(2)
        for reader in ("ann", "bob"):  # both read the same three fish
            for _ in range(3):
                (object_id,) = project.add_objects([("length", _vertices(rng, "p1", "length"), "", "", reader)])
                project.set_record(object_id, ObservationRecord(*TAXA[0]))
        project.set_campaign(CAMPAIGN)
        project.set_deployment(DEPLOYMENT)
        counts = {}
        for reader in (None, "ann", "bob"):
            folder = tmp_path / f"out-{reader}"
            folder.mkdir()
            warnings = []
            export_archive(project, folder, reader=reader, warnings=warnings)
            # counted together, the two readers' objects are said to be (a double read counts twice)
            assert warnings == ([] if reader else [
                "the objects of 2 annotators (ann 3, bob 3) are counted together: right when they measured "
                "different fish, twice over when the survey was double-read (then export one reader's objects)"])
            (row,) = _table(folder / f"{CAMPAIGN.campaign_id}_Count.txt", "\t")
            counts[reader] = int(row["Count"])
            lengths = _table(folder / f"{CAMPAIGN.campaign_id}_Length.txt", "\t")
            want = {o.id for o in project.objects() if reader is None or o.creator == reader}
            assert {int(r["ObjectID"]) for r in lengths} == want
        assert counts == {None: 6, "ann": 3, "bob": 3}
        with pytest.raises(InvalidParameterError, match="annotator 'carol' measured no object"):
            export_archive(project, tmp_path / "out-ann", reader="carol")
    finally:
        project.close()
