"""Exports: CSV, GeoJSON, PLY and EventMeasure-style tables carry the figures of the one figure path,
written with the csv module, sanitised, all files or none."""

import csv
import io
import json
import os

import numpy as np
import pytest

from usvips.core.deployment import Georeference
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import measure
from usvips.io.export import (
    LENGTH_COLUMNS,
    POINT_COLUMNS,
    cell,
    eventmeasure_tables,
    export,
    geojson,
    object_columns,
    objects_csv,
    ply,
    vertices_csv,
)

COV = np.diag([1e-6, 1e-6, 4e-6])


def _objects():
    return [measure("point", np.array([[0.1, 0.2, -2.0]]), COV[None], 0.004, 2.0, id="1", attribute="rock"),
            measure("length", np.array([[0, 0, -2.0], [0.3, 0.4, -2.0]]), np.stack([COV, COV]), 0.004, 2.0, id="2",
                    attribute="cod"),
            measure("polygon", np.array([[0, 0, -2.0], [1, 0, -2], [1, 1, -2], [0, 1, -2]]), np.stack([COV] * 4),
                    id="3", attribute="sponge"),
            measure("arc", np.array([[0, 0, -2.0], [0.3, 0, -2.0], [0.3, 0.4, -2.0]]), np.stack([COV] * 3), id="4"),
            measure("circle", np.array([[0.5, 0, -2.0], [0, 0.5, -2.0], [-0.5, 0, -2.0]]), np.stack([COV] * 3),
                    id="5", attribute="burrow")]


def test_csv_geojson_and_ply_carry_the_figures():
    objects = _objects()
    rows = list(csv.DictReader(io.StringIO(objects_csv(objects))))
    assert list(rows[0]) == object_columns()
    assert float(rows[1]["length"]) == pytest.approx(0.5) and float(rows[1]["s_length"]) == objects[1].main.sigma
    assert float(rows[2]["area"]) == pytest.approx(1.0) and float(rows[0]["sZ"]) == pytest.approx(0.002)
    assert float(rows[2]["s_planarity_rms"]) > 0 and rows[2]["ray_rms_m"] == "" and rows[1]["ray_rms_m"] == "0.004"
    assert float(rows[3]["length"]) == pytest.approx(0.7) and rows[3]["kind"] == "arc"
    assert float(rows[4]["diameter"]) == pytest.approx(1.0) and float(rows[4]["s_diameter"]) > 0
    assert rows[0]["covariance"] == "per-vertex"
    assert len(list(csv.DictReader(io.StringIO(vertices_csv(objects))))) == 13
    collection = json.loads(geojson(objects, Georeference(-32.0, 115.5, 10.0, 0.0)))
    kinds = [f["geometry"]["type"] for f in collection["features"]]
    assert kinds == ["Point", "LineString", "Polygon", "LineString", "Polygon"]
    ring = collection["features"][2]["geometry"]["coordinates"][0]
    assert ring[0] == ring[-1] and len(ring[0]) == 3
    assert collection["features"][1]["properties"]["length"] == pytest.approx(0.5)
    assert collection["features"][1]["properties"]["s_length"] == objects[1].main.sigma
    circle = collection["features"][4]["geometry"]["coordinates"][0]
    assert len(circle) == 73 and circle[0] == circle[-1]
    text = ply(objects[:3])
    assert "element vertex 7" in text and "element edge 5" in text


def test_export_by_suffix_and_unknown_formats(tmp_path):
    export(_objects(), tmp_path / "objects.geojson", georeference=Georeference(10.0, 20.0))
    assert json.loads((tmp_path / "objects.geojson").read_text())["type"] == "FeatureCollection"
    with pytest.raises(InvalidParameterError, match="no georeference.*export CSV"):
        export(_objects(), tmp_path / "local.geojson")
    assert not (tmp_path / "local.geojson").exists()
    with pytest.raises(InvalidParameterError, match="unknown export format"):
        export(_objects(), tmp_path / "objects.xyz")
    assert not (tmp_path / "objects.xyz").exists()


def test_cells_are_sanitised_for_spreadsheets_and_tab_tables():
    assert cell("=HYPERLINK(1)") == "'=HYPERLINK(1)" and cell("+1 cod") == "'+1 cod" and cell("@a") == "'@a"
    assert cell("-0.5") == "-0.5" and cell(-0.5) == "-0.5" and cell("-cod") == "'-cod" and cell(3) == "3"
    assert cell("a\tb\nc", flatten=True) == "a b c" and cell("cod") == "cod"
    hostile = measure("length", np.array([[0, 0, -2.0], [0.3, 0.4, -2.0]]), np.stack([COV, COV]), id="x\ty",
                      attribute="=cmd|' /C calc'!A0", notes="two\nlines\tand tab")
    rows = list(csv.reader(io.StringIO(objects_csv([hostile]))))
    assert len(rows) == 2 and len(rows[1]) == len(rows[0])
    record = dict(zip(rows[0], rows[1], strict=True))
    assert record["attribute"].startswith("'=") and record["notes"] == "two\nlines\tand tab"  # quoted, kept
    tables = eventmeasure_tables([hostile], opcode="OP\t1\n")
    lines = tables["Lengths"].rstrip("\n").split("\n")
    assert len(lines) == 2 and all(len(line.split("\t")) == len(LENGTH_COLUMNS) for line in lines)
    fields = dict(zip(LENGTH_COLUMNS, lines[1].split("\t"), strict=True))
    assert fields["OpCode"] == "OP 1 " and fields["Comment"] == "two lines and tab"


def _checkem_names(header: list[str]) -> list[str]:
    """Column names as CheckEM's clean_names() makes them: trim, '%' → 'percent', R's make.names (every
    character outside letters, digits, '.' and '_' becomes '.'), dots collapsed to '_', lower case."""
    import re

    names = []
    for name in header:
        name = name.strip().replace("%", "percent")
        name = re.sub(r"[^A-Za-z0-9._]", ".", name)
        name = re.sub(r"\.+", "_", name)
        names.append(name.lower())
    return names


def test_eventmeasure_style_tables_read_as_checkem_reads_them():
    objects = _objects() + [measure("length", np.array([[0, 0, -2.0], [0, 0.3, -2.0]]), np.stack([COV, COV]),
                                    0.003, 2.0, id="6", attribute="Sparidae Pagrus auratus", notes="tail\tbent")]
    tables = eventmeasure_tables(objects, opcode="OP1", images={"2": ("L001.MP4", "1200", "R001.MP4", "1203")})
    assert set(tables) >= {"Lengths", "3DPoints", "Polygons", "Circles"}
    rows = [line.split("\t") for line in tables["Lengths"].rstrip("\n").splitlines()]
    assert rows[0] == LENGTH_COLUMNS and len(rows) == 4 and all(len(r) == len(LENGTH_COLUMNS) for r in rows)
    # what CheckEM's server.R selects and converts from a lengths file, after its clean_names()
    names = _checkem_names(rows[0])
    for needed in ("opcode", "period", "family", "genus", "species", "number", "code", "length", "precision",
                   "rms", "range", "comment", "frameleft", "frameright", "periodtime", "time"):
        assert needed in names, needed
    first = dict(zip(names, rows[1], strict=True))
    assert first["opcode"] == "OP1" and first["length"] == "500.0" and first["rms"] == "4.0"
    assert float(first["precision"]) == objects[1].main.sigma * 1000
    assert first["species"] == "cod" and first["number"] == "1" and first["frameleft"] == "1200"
    # CheckEM's default filters: range < 10 m, RMS < 20 mm, precision / length < 10 %
    assert float(first["range"]) < 10_000 and float(first["rms"]) < 20
    assert float(first["precision"]) / float(first["length"]) * 100 < 10
    assert float(first["direction"]) == pytest.approx(90.0, abs=15)  # across the line of sight
    arc = dict(zip(names, rows[2], strict=True))
    assert float(arc["length"]) == pytest.approx(700.0) and arc["comment"] == "arc of 3 vertices"
    second = dict(zip(names, rows[3], strict=True))
    assert (second["family"], second["genus"], second["species"]) == ("Sparidae", "Pagrus", "auratus")
    assert second["comment"] == "tail bent"  # a tab in the notes must not break the table
    point_rows = [line.split("\t") for line in tables["3DPoints"].rstrip("\n").splitlines()]
    assert point_rows[0] == POINT_COLUMNS
    point_names = _checkem_names(point_rows[0])
    for needed in ("opcode", "x", "y", "z", "sx", "sy", "sz", "rms", "range", "species", "number"):
        assert needed in point_names, needed
    assert dict(zip(point_names, point_rows[1], strict=True))["z"] == "-2000.0"
    polygons = list(csv.DictReader(io.StringIO(tables["Polygons"]), dialect="excel-tab"))
    assert len(polygons) == 1 and float(polygons[0]["Area"]) == pytest.approx(1e6)
    assert float(polygons[0]["sPlanarityRms"]) > 0 and polygons[0]["Species"] == "sponge"
    circles = list(csv.DictReader(io.StringIO(tables["Circles"]), dialect="excel-tab"))
    assert float(circles[0]["Diameter"]) == pytest.approx(1000.0) and circles[0]["Vertices"] == "3"


def test_eventmeasure_files_by_suffix_all_or_nothing(tmp_path, monkeypatch):
    written = export(_objects(), tmp_path / "survey.em.txt")
    assert sorted(p.name for p in written) == sorted(p.name for p in tmp_path.iterdir())
    assert (tmp_path / "survey_Lengths.txt").read_text().startswith("OpCode\t")
    assert "\t-2000.0\t" in (tmp_path / "survey_3DPoints.txt").read_text()
    before = {p.name: p.read_text() for p in tmp_path.iterdir()}
    calls = {"n": 0}
    real = os.replace

    def failing(source, target):
        calls["n"] += 1
        if calls["n"] == 4:  # the second table's rename into place
            raise OSError(28, "No space left on device")
        return real(source, target)

    monkeypatch.setattr(os, "replace", failing)
    with pytest.raises(OSError):
        export(_objects()[:2], tmp_path / "survey.em.txt")
    monkeypatch.setattr(os, "replace", real)
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == before  # old set intact, no temporaries
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    calls["n"] = 0
    monkeypatch.setattr(os, "replace", failing)
    with pytest.raises(OSError):
        export(_objects(), fresh / "survey.em.txt")
    monkeypatch.setattr(os, "replace", real)
    assert list(fresh.iterdir()) == []


def test_a_closed_arc_has_no_direction_rather_than_a_nan():
    loop = measure("arc", np.array([[0, 0, -2.0], [0.3, 0, -2.0], [0.3, 0.3, -2.0], [0, 0, -2.0]]),
                   np.stack([COV] * 4), id="7")
    row = dict(zip(LENGTH_COLUMNS, eventmeasure_tables([loop])["Lengths"].splitlines()[1].split("\t"), strict=True))
    assert row["Direction"] == "" and float(row["Length"]) == pytest.approx(300 + 300 + 300 * np.sqrt(2))


def test_a_binomial_attribute_is_genus_and_species_and_a_record_fills_every_field():
    """Without a record, "Genus species" splits into Genus and Species (not "Unknown Unknown genusspecies");
    with an observation record, its taxon, code, number, stage, activity and comment fill EventMeasure's
    columns, whatever the attribute says."""
    from usvips.core.observation_record import ObservationRecord

    fish = [measure("length", np.array([[0, 0, -2.0], [0.3, 0.0, -2.0]]), np.stack([COV, COV]), 0.003, 2.0,
                    id=str(i), attribute=attribute, notes=notes)
            for i, (attribute, notes) in enumerate([("Pagrus auratus", ""), ("snapper", "near the bait")], 1)]
    record = ObservationRecord("Sparidae", "Chrysophrys", "auratus", "37353001", 3, "AD", "feeding", "school")
    tables = eventmeasure_tables(fish, opcode="OP", records={"2": record})
    rows = list(csv.DictReader(io.StringIO(tables["Lengths"]), dialect="excel-tab"))
    assert (rows[0]["Family"], rows[0]["Genus"], rows[0]["Species"]) == ("", "Pagrus", "auratus")
    assert rows[0]["Number"] == "1" and rows[0]["Code"] == ""
    second = {k: rows[1][k] for k in ("Family", "Genus", "Species", "Code", "Number", "Stage", "Activity",
                                       "Comment")}
    assert second == {"Family": "Sparidae", "Genus": "Chrysophrys", "Species": "auratus", "Code": "37353001",
                      "Number": "3", "Stage": "AD", "Activity": "feeding", "Comment": "school; near the bait"}


def test_the_objects_csv_carries_the_record_and_where_each_object_was_measured():
    from usvips.core.observation_record import ObservationRecord

    objects = _objects()
    records = {"1": ObservationRecord("Sparidae", "Pagrus", "auratus", "37353001", 3)}
    places = {"1": ("dive-7", "L0042.png", "", "R0042.png", "", ""),
              "2": ("video", "GL010042.MP4", "120", "GR010042.MP4", "123", "0.06672")}
    rows = {r["id"]: r for r in csv.DictReader(io.StringIO(objects_csv(objects, records, places)))}
    assert (rows["1"]["species"], rows["1"]["code"], rows["1"]["number"]) == ("Pagrus auratus", "37353001", "3")
    assert rows["1"]["pair"] == "dive-7" and rows["1"]["file_left"] == "L0042.png" and rows["1"]["time_min"] == ""
    assert (rows["2"]["frame_left"], rows["2"]["frame_right"], rows["2"]["time_min"]) == ("120", "123", "0.06672")
    assert rows["3"]["species"] == "" and rows["3"]["pair"] == ""  # none given: empty cells, not made up


def test_unknown_sigmas_and_rms_are_empty_cells_and_a_missing_length_is_refused():
    """A σ that is not finite (unknown) is an empty cell in every exported table, never "nan"; a length
    or point place that is not finite is refused, naming the object and the column."""
    import dataclasses
    import math
    import re

    def unknown_sigmas(obj):
        return dataclasses.replace(obj, figures=tuple(dataclasses.replace(f, sigma=math.nan) for f in obj.figures),
                                   ray_rms_m=math.nan)

    objects = [unknown_sigmas(o) for o in _objects()]
    tables = eventmeasure_tables(objects, opcode="BRUV1")
    texts = list(tables.values()) + [objects_csv(objects)]
    assert not any(re.search(r"(^|[\t,])(nan|-?inf)($|[\t,])", t, re.I | re.M) for t in texts)
    lengths = list(csv.DictReader(io.StringIO(tables["Lengths"]), dialect="excel-tab"))
    assert lengths[0]["Precision"] == "" and lengths[0]["RMS"] == "" and float(lengths[0]["Length"]) > 0
    broken = dataclasses.replace(objects[1], figures=tuple(dataclasses.replace(f, value=math.nan)
                                                           for f in objects[1].figures))
    with pytest.raises(InvalidParameterError, match="object 2: its Length"):
        eventmeasure_tables([broken], opcode="BRUV1")


@pytest.mark.parametrize(("attribute", "taxon"), [
    ("Sparidae Chrysophrys auratus", ("Sparidae", "Chrysophrys", "auratus")),
    ("Laminariaceae Ecklonia radiata", ("Laminariaceae", "Ecklonia", "radiata")),
    ("left side only", ("", "", "left side only")),  # three words that are no taxon stay whole
    ("Fork partly hidden", ("", "", "Fork partly hidden")),
])
def test_a_free_text_attribute_is_a_taxon_only_when_it_reads_as_one(attribute, taxon):
    fish = [measure("length", np.array([[0, 0, -2.0], [0.3, 0.0, -2.0]]), np.stack([COV, COV]), 0.003, 2.0,
                    id="1", attribute=attribute)]
    rows = list(csv.DictReader(io.StringIO(eventmeasure_tables(fish, opcode="OP")["Lengths"]), dialect="excel-tab"))
    assert (rows[0]["Family"], rows[0]["Genus"], rows[0]["Species"]) == taxon
