"""CheckEM reads our exports: the EventMeasure-style tables and ``_Metadata.csv`` of a project with stored
deployments, read here as CheckEM's R code reads them (``read_em_length``, ``read_metadata``,
``clean_names``; GlobalArchiveManual/CheckEM, R/), sample ids for BRUVs (OpCode) and DOVs
(OpCode-Period), and its default filters: every measurement is kept with its taxonomy and its sample is
in the metadata."""

import csv
import re
from pathlib import Path

import numpy as np
import pytest

from usvips.app.project_export import export_project
from usvips.core.deployment import Deployment
from usvips.core.errors import InvalidParameterError
from usvips.core.observation_record import ObservationRecord
from usvips.io.checkem import METADATA_COLUMNS
from usvips.store import Project
from usvips.store.project import Vertex

COV = np.eye(3) * 1e-6


# ---------------------------------------------------------------------------- CheckEM's reading, in Python
def clean_names(names: list[str]) -> list[str]:
    """CheckEM's clean_names(): trim, '%' → 'percent', R's make.names (characters outside letters, digits,
    '.' and '_' become '.', a leading digit or '_' gets an 'X' before it), runs of '.' → '_', lower case,
    then make.unique with '_'."""
    out: list[str] = []
    for name in names:
        name = name.strip().replace("%", "percent")
        name = re.sub(r"[^A-Za-z0-9._]", ".", name)
        if not re.match(r"[A-Za-z]|\.(?![0-9])", name):
            name = "X" + name
        name = re.sub(r"\.+", "_", name).lower()
        base, n = name, 0
        while name in out:
            n += 1
            name = f"{base}_{n}"
        out.append(name)
    return out


def _na(value: str) -> str | None:
    """readr's reading of a text cell: trimmed; empty or "NA" is NA."""
    value = value.strip()
    return None if value in ("", "NA") else value


def _read(path: Path, dialect: str) -> list[dict]:
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle, dialect=dialect))
    names = clean_names(rows[0])
    return [dict(zip(names, map(_na, row), strict=True)) for row in rows[1:]]


def _paste(*values: str | None) -> str:
    return "-".join("NA" if v is None else v for v in values)  # R's paste(..., sep = "-") of NA is "NA"


def read_em_length(folder: Path, method: str) -> list[dict]:
    """CheckEM's read_em_length(): every *_Lengths.txt and *_3DPoints* file, campaign from the name,
    sample = opcode (BRUVs) or opcode-period (DOVs)."""
    rows = []
    for path in sorted(folder.iterdir()):
        if re.search(r"_Lengths.txt|_3DPoints", path.name):
            for row in _read(path, "excel-tab"):
                row["campaignid"] = re.sub(r"_3DPoints.txt|_Lengths.txt", "", path.name)
                row["sample"] = _paste(row["opcode"], row["period"]) if method == "DOVs" else row["opcode"]
                rows.append(row)
    return rows


LOOKUP = {"Sample": "sample", "Latitude": "latitude_dd", "latitude": "latitude_dd", "Longitude": "longitude_dd",
          "longitude": "longitude_dd", "Location": "location", "Status": "status", "Site": "site", "Depth": "depth_m",
          "depth": "depth_m", "date.time": "date_time", "Observer": "observer_count",
          "Successful.count": "successful_count", "Successful.length": "successful_length"}


def read_metadata(folder: Path, method: str) -> list[dict]:
    """CheckEM's read_metadata(): every *etadata.csv, names cleaned then the GlobalArchive names renamed,
    sample = opcode (BRUVs) or opcode-period (DOVs, opcode and period dropped), and without date_time one
    built from date (YYYYMMDD) and time (HH:MM:SS) — the time zone CheckEM looks up from the position
    is left out here."""
    rows = []
    for path in sorted(folder.glob("*etadata.csv")):
        for row in _read(path, "excel"):
            row = {LOOKUP.get(k, k): v for k, v in row.items()}
            row["campaignid"] = re.sub(r"_Metadata.csv|_metadata.csv", "", path.name)
            if method == "DOVs" and "opcode" in row:
                row["sample"] = _paste(row.pop("opcode"), row.pop("period"))
            elif method == "BRUVs" and "opcode" in row:
                row["sample"] = row["opcode"]
            if "date_time" not in row:
                hour, minute, second = ((row["time"] or "") + "::").split(":")[:3]
                date = row["date"] or ""
                row["date_time"] = (f"{date[:4]}-{date[4:6]}-{date[6:8]}T{hour.zfill(2)}:{minute.zfill(2)}:"
                                    f"{(second or '00').zfill(2)}")
            rows.append(row)
    return rows


def default_filters(rows: list[dict]) -> list[dict]:
    """CheckEM's default length filters: range < 10 m, RMS < 20 mm, precision / length < 10 % (a row
    with NA in any of them is dropped, as dplyr::filter drops NA). 3-D points have no length or
    precision: they pass on range and RMS."""
    kept = []
    for row in rows:
        if row["range"] is None or float(row["range"]) >= 10_000 or row["rms"] is None or float(row["rms"]) >= 20:
            continue
        if "length" in row and (row["length"] is None or row["precision"] is None
                                or float(row["precision"]) / float(row["length"]) * 100 >= 10):
            continue
        kept.append(row)
    return kept


# ---------------------------------------------------------------------------- a project with deployments
CALIBRATION = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport" / "calibration.json"


class _Picker:
    """Picks of points given in the left camera's frame (x right, y up, z toward the image: in front is
    z < 0), seen through the sample calibration in the rig frame with 0.3 px of noise, so that the export
    recomputes each object from its picks (ray RMS and range known, as in a real survey)."""

    def __init__(self, project: Project):
        from usvips.io.calibration_file import calibration_to_dict, load_calibration

        self.calibration = load_calibration(CALIBRATION)
        self.id = project.add_calibration("rov", calibration_to_dict(self.calibration))
        self.rig = self.calibration.rig(0, "rig")
        self.rng = np.random.default_rng(19)

    def vertices(self, points, pair: str, video: str | None = None, frame: int = 0) -> list[Vertex]:
        points = np.asarray(points, float)
        left = self.rig.left.project(points).pixels + self.rng.normal(0, 0.3, (len(points), 2))
        right = self.rig.right.project(points).pixels + self.rng.normal(0, 0.3, (len(points), 2))
        timing = {} if video is None else {"video": video, "frame_left": frame, "frame_right": frame + 2,
                                           "time_s": frame / 25}
        return [Vertex(*a, *b, tuple(p), COV, self.id, pair, **timing)
                for a, b, p in zip(left, right, points, strict=True)]


def _dov_project(path: Path) -> tuple[Project, dict[int, ObservationRecord]]:
    """Two transect videos: T1 with its own deployment and periods A and B, T2 under the project's
    deployment with period C, and an image pair P; fish with records, a fish without one, a point, an arc
    and a polygon."""
    project = Project.create(path)
    for label in ("T1", "T2"):
        files = {}
        for side in ("left", "right"):
            files[side] = path.parent / f"{label}_{side}.mp4"
            files[side].write_bytes(f"{label} {side}".encode())
        project.add_video(label, [(files["left"], 200, 25.0)], [(files["right"], 200, 25.0)], 25.0, 200, (640, 480))
    project.add_pair("P")
    project.add_period("T1", "A", 0, 99)
    project.add_period("T1", "B", 100, 199)
    project.add_period("T2", "C", 0, 199)
    project.set_deployment(Deployment("DOV-01", "2024-03-01", "9:05", -32.0, 115.5, 8.0, "North", "Rottnest",
                                      "No-take", observer="AB"), "T1")
    project.set_deployment(Deployment("DOV-02", "2024-03-02", "14:30:10", -32.1, 115.6, 12.0, "South",
                                      "Rottnest", "Fished", successful_length=False))
    picker = _Picker(project)

    def fish(x: float, y: float, pair: str, frame: int = 0, extra=()) -> list[Vertex]:
        points = [(x, y, -2.5), (x + 0.25, y + 0.02, -2.6), *extra]
        return picker.vertices(points, pair, None if pair == "P" else pair, frame)

    records = {}
    snapper = ObservationRecord("Sparidae", "Chrysophrys", "auratus", "37353001", 2, "AD", "passing")
    wrasse = ObservationRecord("Labridae", "Notolabrus", "tetricus", "37384045", 1, "J")
    for vertices, record in ((fish(-0.3, 0.0, "T1", 10), snapper), (fish(-0.2, 0.1, "T1", 150), wrasse),
                             (fish(-0.3, -0.1, "T2", 20), snapper), (fish(-0.1, 0.2, "P"), wrasse),
                             (fish(0.0, 0.0, "T1", 30)[:1], wrasse), (fish(-0.2, -0.2, "T2", 40), None)):
        kind = "point" if len(vertices) == 1 else "length"
        object_id = project.add_object(kind, vertices, attribute="Pagrus auratus")
        if record is not None:
            project.set_record(object_id, record)
            records[object_id] = record
    project.add_object("arc", fish(-0.3, 0.3, "T1", 60, [(0.1, 0.35, -2.6)]), attribute="Pagrus auratus")
    project.add_object("polygon", picker.vertices([(-0.3, -0.3, -3.0), (0.2, -0.3, -3.0), (0.2, 0.2, -3.0)], "P"))
    return project, records


@pytest.mark.parametrize("method", ["DOVs", "BRUVs"])
def test_checkem_reads_every_measurement_with_its_taxonomy_and_its_sample_in_the_metadata(tmp_path, method):
    project, records = _dov_project(tmp_path / "survey.usvips")
    out = tmp_path / "out"
    out.mkdir()
    assert export_project(project, out / "Campaign1.em.txt") == 8
    project.close()
    assert sorted(p.name for p in out.iterdir()) == ["Campaign1_3DPoints.txt", "Campaign1_Circles.txt",
                                                      "Campaign1_Lengths.txt", "Campaign1_Metadata.csv",
                                                      "Campaign1_Polygons.txt"]
    lengths = read_em_length(out, method)
    metadata = read_metadata(out, method)
    assert {r["campaignid"] for r in lengths + metadata} == {"Campaign1"}
    # every length and point (arc included) read, kept by the default filters, with its taxonomy
    kept = default_filters(lengths)
    assert len(kept) == len(lengths) == 7
    lines = [r for r in kept if "length" in r]
    assert len(lines) == 6 and sum(r["comment"] == "arc of 3 vertices" for r in lines) == 1
    recorded = [r for r in kept if r["code"]]
    assert sorted((r["family"], r["genus"], r["species"], r["code"], r["number"]) for r in recorded) == sorted(
        (x.family, x.genus, x.species, x.code, str(x.number)) for x in records.values())
    unrecorded = [r for r in kept if not r["code"]]
    assert {(r["genus"], r["species"]) for r in unrecorded} == {("Pagrus", "auratus")}
    # every sample measured is in the metadata, once
    samples = [m["sample"] for m in metadata]
    assert {r["sample"] for r in kept} <= set(samples)
    if method == "DOVs":
        assert sorted(samples) == ["DOV-01-A", "DOV-01-B", "DOV-02-C", "DOV-02-NA"]
        assert len(set(samples)) == len(samples)
        by_sample = {m["sample"]: m for m in metadata}
        assert {r["sample"] for r in kept} == {"DOV-01-A", "DOV-01-B", "DOV-02-C", "DOV-02-NA"}
        first = by_sample["DOV-01-A"]
        assert (first["latitude_dd"], first["longitude_dd"], first["depth_m"]) == ("-32.0", "115.5", "8.0")
        assert first["date_time"] == "2024-03-01T09:05:00" and first["status"] == "No-take"
        assert first["successful_count"] == "Yes" and by_sample["DOV-02-C"]["successful_length"] == "No"
        assert by_sample["DOV-02-NA"]["site"] == "South"  # the image-pair fish: the project's deployment
    else:
        assert set(samples) == {"DOV-01", "DOV-02"}
        assert {r["sample"] for r in kept} == {"DOV-01", "DOV-02"}
    polygons = list(csv.DictReader((out / "Campaign1_Polygons.txt").open(encoding="utf-8"), dialect="excel-tab"))
    assert len(polygons) == 1 and float(polygons[0]["Area"]) == pytest.approx(0.125e6, rel=0.02)


def test_metadata_columns_clean_to_the_names_checkem_matches():
    names = [LOOKUP.get(n, n) for n in METADATA_COLUMNS]
    cleaned = {LOOKUP.get(n, n) for n in clean_names(names)}
    assert {"opcode", "period", "sample", "date", "time", "latitude_dd", "longitude_dd", "depth_m", "site",
            "location", "status", "successful_count", "successful_length"} <= cleaned


def test_a_project_without_deployments_still_gives_every_sample_a_metadata_row(tmp_path):
    project = Project.create(tmp_path / "p.usvips")
    project.add_object("length", [Vertex(1, 2, 3, 4, (0, 0, -2.0), COV), Vertex(5, 6, 7, 8, (0.3, 0, -2.0), COV)],
                       attribute="Pagrus auratus")
    out = tmp_path / "x.em.txt"
    export_project(project, out, opcode="OP7")
    metadata = read_metadata(tmp_path, "BRUVs")
    assert [(m["sample"], m["successful_length"]) for m in metadata] == [("OP7", "Yes")]
    assert {r["sample"] for r in read_em_length(tmp_path, "BRUVs")} == {"OP7"}


@pytest.mark.parametrize("values, message", [
    (dict(opcode=""), "opcode: must not be empty"),
    (dict(opcode="A", date="2024-02-30"), "date: must be a date YYYY-MM-DD"),
    (dict(opcode="A", time="9:61"), "time: must be a time"),
    (dict(opcode="A", latitude=-90.5), "latitude: must be between -90 and 90"),
    (dict(opcode="A", longitude="east"), "longitude: must be a number of degrees"),
    (dict(opcode="A", depth_m=-3), "depth: must be between 0 and"),
    (dict(opcode="A", site="a\tb"), "site: must be one line"),
    (dict(opcode="A", successful_count="perhaps"), "successful_count: must be yes or no"),
])
def test_bad_deployment_metadata_is_named(values, message):
    with pytest.raises(InvalidParameterError, match=message):
        Deployment(**values)
