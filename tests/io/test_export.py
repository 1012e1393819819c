import csv
import io
import json

import numpy as np
import pytest

from usvips.core.errors import InvalidParameterError
from usvips.core.measure import MeasuredObject
from usvips.io.export import export, geojson, objects_csv, ply, vertices_csv

COV = np.diag([1e-6, 1e-6, 4e-6])


def _objects():
    return [MeasuredObject("1", "point", np.array([[0.1, 0.2, -2.0]]), COV[None], "rock"),
            MeasuredObject("2", "line", np.array([[0, 0, -2.0], [0.3, 0.4, -2.0]]), np.stack([COV, COV]), "cod"),
            MeasuredObject("3", "polygon", np.array([[0, 0, -2.0], [1, 0, -2], [1, 1, -2], [0, 1, -2]]),
                           np.stack([COV] * 4), "sponge")]


def test_csv_geojson_and_ply_carry_the_figures():
    rows = list(csv.DictReader(io.StringIO(objects_csv(_objects()))))
    assert float(rows[1]["length"]) == pytest.approx(0.5) and float(rows[1]["s_length"]) > 0
    assert float(rows[2]["area"]) == pytest.approx(1.0) and float(rows[0]["sZ"]) == pytest.approx(0.002)
    assert len(list(csv.DictReader(io.StringIO(vertices_csv(_objects()))))) == 7
    collection = json.loads(geojson(_objects()))
    kinds = [f["geometry"]["type"] for f in collection["features"]]
    assert kinds == ["Point", "LineString", "Polygon"]
    ring = collection["features"][2]["geometry"]["coordinates"][0]
    assert ring[0] == ring[-1] and len(ring[0]) == 3
    text = ply(_objects())
    assert "element vertex 7" in text and "element edge 5" in text


def test_export_by_suffix_and_unknown_formats(tmp_path):
    export(_objects(), tmp_path / "objects.geojson")
    assert json.loads((tmp_path / "objects.geojson").read_text())["type"] == "FeatureCollection"
    with pytest.raises(InvalidParameterError, match="unknown export format"):
        export(_objects(), tmp_path / "objects.xyz")
    assert not (tmp_path / "objects.xyz").exists()


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
    from usvips.io.export import LENGTH_COLUMNS, POINT_COLUMNS, eventmeasure_tables

    objects = _objects() + [MeasuredObject("4", "line", np.array([[0, 0, -2.0], [0, 0.3, -2.0]]),
                                           np.stack([COV, COV]), "Sparidae Pagrus auratus", "tail\tbent")]
    lengths, points = eventmeasure_tables(objects, opcode="OP1", rms_m={"2": 0.004},
                                          images={"2": ("L001.MP4", "1200", "R001.MP4", "1203")})
    rows = [line.split("\t") for line in lengths.rstrip("\n").splitlines()]
    assert rows[0] == LENGTH_COLUMNS and len(rows) == 3 and all(len(r) == len(LENGTH_COLUMNS) for r in rows)
    # what CheckEM's server.R selects and converts from a lengths file, after its clean_names()
    names = _checkem_names(rows[0])
    for needed in ("opcode", "period", "family", "genus", "species", "number", "code", "length", "precision",
                   "rms", "range", "comment", "frameleft", "frameright", "periodtime", "time"):
        assert needed in names, needed
    first = dict(zip(names, rows[1], strict=True))
    assert first["opcode"] == "OP1" and first["length"] == "500.0" and first["rms"] == "4.00"
    assert first["species"] == "cod" and first["number"] == "1" and first["frameleft"] == "1200"
    # CheckEM's default filters: range < 10 m, RMS < 20 mm, precision / length < 10 %
    assert float(first["range"]) < 10_000 and float(first["rms"]) < 20
    assert float(first["precision"]) / float(first["length"]) * 100 < 10
    assert float(first["direction"]) == pytest.approx(90.0, abs=15)  # across the line of sight
    second = dict(zip(names, rows[2], strict=True))
    assert (second["family"], second["genus"], second["species"]) == ("Sparidae", "Pagrus", "auratus")
    assert second["comment"] == "tail bent"  # a tab in the notes must not break the table
    point_rows = [line.split("\t") for line in points.rstrip("\n").splitlines()]
    assert point_rows[0] == POINT_COLUMNS
    point_names = _checkem_names(point_rows[0])
    for needed in ("opcode", "x", "y", "z", "sx", "sy", "sz", "rms", "range", "species", "number"):
        assert needed in point_names, needed
    assert dict(zip(point_names, point_rows[1], strict=True))["z"] == "-2000.0"


def test_eventmeasure_files_by_suffix(tmp_path):
    export(_objects(), tmp_path / "survey.em.txt")
    assert (tmp_path / "survey_Lengths.txt").read_text().startswith("OpCode\t")
    assert "\t-2000.0\t" in (tmp_path / "survey_3DPoints.txt").read_text()
