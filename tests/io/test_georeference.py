"""Georeferenced GeoJSON checked with a GIS library (pyproj.Geod on WGS 84) over many random origins,
headings and objects: lengths and areas on the ellipsoid equal the project's metres within 1e-6, the
heading turns +X where it says, exterior rings are counter-clockwise, heights are −depth + Z; PLY (ASCII
and binary) carries every vertex's sigmas and attributes, read back by a small parser."""

import json

import numpy as np
import pytest
from pyproj import Geod

from usvips.core.deployment import Georeference
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import measure
from usvips.io.export import export, geojson, ply, ply_binary
from usvips.io.georeference import object_to_geographic

GEOD = Geod(ellps="WGS84")


def _random_georeference(rng) -> Georeference:
    return Georeference(rng.uniform(-80, 80), rng.uniform(-179, 179), rng.uniform(0, 60), rng.uniform(0, 360))


def _random_objects(rng, scale: float = 1.0) -> list:
    """A length, an arc, a polygon and a circle lying horizontally at a random height (Z), a point, with
    random per-vertex covariances; ``scale``: their size (1: a fish, metres)."""
    z = rng.uniform(-5, 0)
    cov = lambda n: np.stack([np.diag(rng.uniform(1e-7, 4e-6, 3)) for _ in range(n)])  # noqa: E731
    centre = rng.uniform(-3, 3, 2)

    def flat(points):
        points = np.asarray(points, float) * scale
        return np.column_stack([points + centre * scale, np.full(len(points), z)])

    angles = np.sort(rng.uniform(0, 2 * np.pi, 5))
    polygon = flat(np.column_stack([np.cos(angles), np.sin(angles)]) * rng.uniform(0.2, 2.0, (5, 1)))
    if rng.random() < 0.5:
        polygon = polygon[::-1]  # wound either way in the project frame
    return [measure("length", flat(rng.uniform(-1, 1, (2, 2))), cov(2), id="1", attribute="Pagrus auratus"),
            measure("arc", flat(rng.uniform(-1, 1, (4, 2))), cov(4), id="2"),
            measure("polygon", polygon, cov(5), id="3", attribute="sponge"),
            measure("circle", flat([[0.4, 0], [0, 0.4], [-0.4, 0.05]]), cov(3), id="4"),
            measure("point", flat(rng.uniform(-1, 1, (1, 2))), cov(1), id="5")]


@pytest.mark.parametrize("scale, check_area", [(1.0, False), (100.0, True)])
def test_lengths_and_areas_on_the_ellipsoid_equal_the_measured_metres_over_random_georeferences(scale, check_area):
    """Fish-sized lengths, and plot-sized (100 m) lengths and areas: Geod's area of a 1 m² polygon is
    numerical noise at 1e-5 relative (its absolute error is set by the Earth's area), so areas are checked
    where the GIS can measure them."""
    rng = np.random.default_rng(2026)
    worst = 0.0
    for _ in range(60):
        georeference = _random_georeference(rng)
        objects = _random_objects(rng, scale)
        collection = json.loads(geojson(objects, georeference))
        assert collection["type"] == "FeatureCollection" and "crs" not in collection
        features = {f["id"]: f for f in collection["features"]}
        for key in ("1", "2"):
            lon, lat, height = np.array(features[key]["geometry"]["coordinates"]).T
            length = GEOD.line_length(lon, lat)
            expected = next(o for o in objects if o.id == key).main.value
            worst = max(worst, abs(length / expected - 1))
            assert features[key]["geometry"]["type"] == "LineString"
            assert np.allclose(height, objects[0].points[0, 2] - georeference.depth_m, atol=1e-6)
        for key in ("3", "4"):
            ring = np.array(features[key]["geometry"]["coordinates"][0])
            assert np.array_equal(ring[0], ring[-1])
            area, _ = GEOD.polygon_area_perimeter(ring[:, 0], ring[:, 1])
            assert area > 0  # pyproj: positive for a counter-clockwise ring (RFC 7946's right-hand rule)
            obj = next(o for o in objects if o.id == key)
            expected = obj.figure("area").value if key == "3" else _shoelace(obj)
            if check_area:
                worst = max(worst, abs(area / expected - 1))
        props = features["1"]["properties"]
        assert props["length"] == objects[0].main.value and props["s_length"] == objects[0].main.sigma
        assert props["attribute"] == "Pagrus auratus" and collection["usvips"]["units"]["length"] == "m"
        point = features["5"]["geometry"]["coordinates"]
        assert len(point) == 3 and -180 <= point[0] <= 180 and -90 <= point[1] <= 90
    assert worst < 1e-6, worst


def _shoelace(circle) -> float:
    """The area (m²) of a circle's exported outline polygon in the project frame."""
    from usvips.core.measurements import kind

    outline = np.asarray(kind("circle").outline(circle.points))[:, :2]
    x, y = outline[:, 0], outline[:, 1]
    return abs(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1])) / 2


def test_the_heading_turns_x_to_its_azimuth_and_the_origin_is_where_it_says():
    rng = np.random.default_rng(7)
    for _ in range(40):
        g = _random_georeference(rng)
        lonlat = object_to_geographic(g, np.array([[0, 0, 0], [2.0, 0, 0], [0, 3.0, -1.0]]))
        assert lonlat[0] == pytest.approx([g.longitude, g.latitude, -g.depth_m], abs=1e-9)
        azimuth, _, distance = GEOD.inv(lonlat[0, 0], lonlat[0, 1], lonlat[1, 0], lonlat[1, 1])
        assert (azimuth - g.heading_deg + 180) % 360 - 180 == pytest.approx(0, abs=1e-6)
        assert distance == pytest.approx(2.0, rel=1e-6)
        azimuth, _, _ = GEOD.inv(lonlat[0, 0], lonlat[0, 1], lonlat[2, 0], lonlat[2, 1])
        assert (azimuth - (g.heading_deg - 90) + 180) % 360 - 180 == pytest.approx(0, abs=1e-6)  # +Y: 90° left
        assert lonlat[2, 2] == pytest.approx(-1.0 - g.depth_m, abs=1e-6)


@pytest.mark.parametrize("values, message", [
    ((91, 0), "latitude: must be between -90 and 90"), ((0, -180.5), "longitude: must be between -180 and 180"),
    ((0, 0, -1), "depth: must be between 0"), ((0, 0, 0, 400), "heading: must be between -360 and 360"),
    ((float("nan"), 0), "latitude: must be between"), (("north", 0), "latitude: must be a number"),
])
def test_a_georeference_out_of_range_is_one_clear_line(values, message):
    with pytest.raises(InvalidParameterError, match=message):
        Georeference(*values)


def test_geojson_without_a_georeference_is_refused_in_one_line(tmp_path):
    objects = _random_objects(np.random.default_rng(1))
    with pytest.raises(InvalidParameterError) as error:
        export(objects, tmp_path / "fish.geojson")
    assert "\n" not in str(error.value) and "set-georeference" in str(error.value) and "CSV" in str(error.value)
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------- PLY
_TYPES = {"double": "<f8", "float": "<f4", "int": "<i4", "uint": "<u4", "uchar": "u1", "char": "i1", "short": "<i2",
          "ushort": "<u2"}


def read_ply(data: bytes) -> tuple[dict[str, np.ndarray], list[str]]:
    """A small PLY reader (ASCII and binary little-endian; scalar properties only): element name →
    structured array, and the header's comments."""
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert header[0] == "ply"
    form = header[1].split()[1]
    elements, comments = [], []
    for line in header[2:-1]:
        words = line.split()
        if words[0] == "comment":
            comments.append(line[len("comment "):])
        elif words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            elements[-1][2].append((words[2], _TYPES[words[1]]))
    out, body = {}, data[end:]
    if form == "ascii":
        rows = iter(body.decode("ascii").splitlines())
        for name, count, properties in elements:
            values = [tuple(float(v) for v in next(rows).split()) for _ in range(count)]
            out[name] = np.array(values, dtype=[(p, "f8") for p, _ in properties]) if values else np.zeros(0)
        assert next(rows, None) is None
    else:
        assert form == "binary_little_endian"
        offset = 0
        for name, count, properties in elements:
            dtype = np.dtype(properties)
            out[name] = np.frombuffer(body, dtype, count, offset)
            offset += dtype.itemsize * count
        assert offset == len(body)
    return out, comments


@pytest.mark.parametrize("binary", [False, True])
def test_ply_carries_sigmas_and_attributes_per_vertex(binary):
    objects = _random_objects(np.random.default_rng(5))
    data = ply_binary(objects) if binary else ply(objects).encode("ascii")
    elements, comments = read_ply(data)
    vertices, edges = elements["vertex"], elements["edge"]
    kinds = {line.split()[2]: int(line.split()[1]) for line in comments if line.startswith("kind ")}
    assert "object 1 attribute Pagrus auratus" in comments and "object 3 attribute sponge" in comments
    for obj in objects:
        mine = vertices[vertices["object"] == int(obj.id)]
        assert np.all(mine["kind"] == kinds[obj.kind])
        assert np.all(mine["main"] == obj.main.value) and np.all(mine["s_main"] == obj.main.sigma)
        if obj.kind != "circle":
            assert np.array_equal(np.column_stack([mine["x"], mine["y"], mine["z"]]), obj.points)
            assert np.array_equal(np.column_stack([mine["sx"], mine["sy"], mine["sz"]]), obj.vertex_sigmas)
            assert list(mine["vertex"]) == list(range(len(obj.points)))
        else:
            assert len(mine) == 72 and np.allclose(np.hypot(mine["x"] - mine["x"].mean(), mine["y"] - mine["y"].mean()),
                                                   obj.figure("diameter").value / 2)
    assert np.all(np.isnan(vertices["ray_rms"]))  # not known for these objects: NaN, not a made-up zero
    # edges: 1 (length) + 3 (arc) + 5 (closed polygon) + 72 (closed circle)
    assert len(edges) == 1 + 3 + 5 + 72 and edges["vertex1"].max() < len(vertices)
    again = read_ply(ply_binary(objects) if not binary else ply(objects).encode("ascii"))[0]["vertex"]
    for name in vertices.dtype.names:
        assert np.array_equal(again[name], vertices[name], equal_nan=True)


# ---------------------------------------------------------------------------- georeference from points
def _geographic(georeference, xyz, noise_m=0.0, rng=None):
    """id → (latitude, longitude, depth) of object-frame points through ``georeference``, with Gaussian
    noise (m) in east, north and depth."""
    from usvips.io.georeference import object_to_enu

    enu_noise = rng.normal(0, noise_m, (len(xyz), 3)) if noise_m else np.zeros((len(xyz), 3))
    heading = np.radians(georeference.heading_deg)
    # a noise vector in east/north is an object-frame offset turned back by the heading
    back = np.array([[np.sin(heading), np.cos(heading)], [-np.cos(heading), np.sin(heading)]])
    shifted = xyz.copy()
    shifted[:, :2] += enu_noise[:, :2] @ back.T
    shifted[:, 2] += enu_noise[:, 2]
    assert np.allclose(object_to_enu(georeference, shifted)[:, :2] - object_to_enu(georeference, xyz)[:, :2],
                       enu_noise[:, :2])
    geo = object_to_geographic(georeference, shifted)
    return {str(i): (lat, lon, -h) for i, (lon, lat, h) in enumerate(geo)}


def test_the_georeference_is_recovered_from_control_points_with_geographic_coordinates():
    from usvips.core.observations import ControlPoints
    from usvips.io.georeference import georeference_from_points

    rng = np.random.default_rng(11)
    for _ in range(40):
        truth = _random_georeference(rng)
        xyz = rng.uniform(-30, 30, (int(rng.integers(2, 9)), 3))
        control = ControlPoints(tuple(str(i) for i in range(len(xyz))), xyz)
        fitted, fit, ids = georeference_from_points(control, _geographic(truth, xyz))
        assert len(ids) == len(xyz) and fit.rms_horizontal_m < 1e-6 and abs(fit.scale - 1) < 1e-8
        moved = GEOD.inv(truth.longitude, truth.latitude, fitted.longitude, fitted.latitude)[2]
        assert moved < 1e-6 and fitted.depth_m == pytest.approx(truth.depth_m, abs=1e-9)
        assert (fitted.heading_deg - truth.heading_deg + 180) % 360 - 180 == pytest.approx(0, abs=1e-7)


def test_with_noisy_positions_the_fit_residual_is_the_noise():
    """GNSS-like noise σ on east, north and depth of 12 points: the horizontal residual RMS over many
    cases is σ·√((2n − 3)/(2n)) per point (3 fitted parameters from 2n coordinates) and the depth RMS
    σ·√((n − 1)/n); the mean of their squares over the cases, normalised, is 1."""
    from usvips.core.observations import ControlPoints
    from usvips.io.georeference import georeference_from_points

    rng = np.random.default_rng(12)
    sigma, n, horizontal, depth = 0.05, 12, [], []
    for _ in range(120):
        truth = _random_georeference(rng)
        xyz = rng.uniform(-30, 30, (n, 3))
        control = ControlPoints(tuple(str(i) for i in range(n)), xyz)
        _, fit, _ = georeference_from_points(control, _geographic(truth, xyz, sigma, rng))
        horizontal.append(fit.rms_horizontal_m ** 2 / (sigma ** 2 * (2 * n - 3) / n))
        depth.append(fit.rms_depth_m ** 2 / (sigma ** 2 * (n - 1) / n))
    assert np.mean(horizontal) == pytest.approx(1.0, abs=0.12) and np.mean(depth) == pytest.approx(1.0, abs=0.15)


def test_points_that_cannot_fix_a_frame_are_named(tmp_path):
    from usvips.core.errors import DegenerateGeometryError, InputFileError
    from usvips.core.observations import ControlPoints
    from usvips.io.georeference import georeference_from_points, read_geographic_points

    control = ControlPoints(("a", "b", "c"), np.array([[1.0, 2, 0], [1.0, 2, -1], [5, 5, 0]]))
    with pytest.raises(InvalidParameterError, match="1 of their ids are control points"):
        georeference_from_points(control, {"a": (-32, 115, 5), "zz": (-32, 115, 5)})
    with pytest.raises(DegenerateGeometryError, match="one horizontal position"):
        georeference_from_points(control, {"a": (-32, 115, 5), "b": (-32, 115, 6)})
    path = tmp_path / "geo.csv"
    path.write_text("id,latitude,longitude,depth\na,-32,115,5\nb,-95,115,5\n")
    with pytest.raises(InputFileError, match=r"line 3.*latitude: -95 is not between -90 and 90"):
        read_geographic_points(path)
    path.write_text("id,lat,lon\na,1,2\n")
    with pytest.raises(InputFileError, match="missing column"):
        read_geographic_points(path)


def test_set_georeference_from_points_on_the_command_line(tmp_path, capsys):
    from usvips.cli import main
    from usvips.core.observations import ControlPoints
    from usvips.store import Project

    rng = np.random.default_rng(13)
    truth = Georeference(-32.01, 115.52, 9.0, 123.0)
    xyz = rng.uniform(-10, 10, (5, 3))
    path = tmp_path / "p.usvips"
    with Project.create(path) as project:
        project.set_control(ControlPoints(tuple(f"c{i}" for i in range(5)), xyz))
    rows = [f"c{i},{float(lat)!r},{float(lon)!r},{float(depth)!r}"
            for i, (lat, lon, depth) in _geographic(truth, xyz).items()]
    (tmp_path / "geo.csv").write_text("id,latitude,longitude,depth\n" + "\n".join(rows) + "\n")
    assert main(["project", "set-georeference", str(path), "--points", str(tmp_path / "geo.csv")]) == 0
    assert "fitted to 5 points" in capsys.readouterr().out
    with Project.open(path, read_only=True) as project:
        stored = project.georeference()
    assert stored.heading_deg == pytest.approx(123.0, abs=1e-7) and stored.depth_m == pytest.approx(9.0)
    # geographic points of other places: a scale far from 1, refused in one line, nothing stored
    far = [f"c{i},{float(lat)!r},{float(lon)!r},{float(depth)!r}"
           for i, (lat, lon, depth) in _geographic(truth, xyz * [3, 3, 1]).items()]
    (tmp_path / "bad.csv").write_text("id,latitude,longitude,depth\n" + "\n".join(far) + "\n")
    assert main(["project", "set-georeference", str(path), "--points", str(tmp_path / "bad.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "would scale them by 3.0" in err
    with Project.open(path, read_only=True) as project:
        assert project.georeference() == stored


def test_features_across_the_antimeridian_are_cut_there_and_keep_their_lengths_and_areas():
    """RFC 7946 §3.1.9 over random plots straddling ±180° (Fiji, the Aleutians): a crossing line or polygon
    becomes a MultiLineString or MultiPolygon whose parts lie each on one side within [−180, 180], are
    counter-clockwise, and add up to the measured length and area on the ellipsoid."""
    rng = np.random.default_rng(180)
    crossing, worst = 0, 0.0
    for _ in range(40):
        latitude = rng.uniform(-70, 70)
        longitude = 180.0 - rng.uniform(-1, 1) * 300.0 / (111_320.0 * np.cos(np.radians(latitude)))
        georeference = Georeference(latitude, (longitude + 180.0) % 360.0 - 180.0, rng.uniform(0, 60),
                                    rng.uniform(0, 360))
        objects = _random_objects(rng, scale=100.0)
        angles = np.linspace(0, 2 * np.pi, 6)[:-1] + rng.uniform(-0.5, 0.5, 5)  # gaps < π: a simple polygon
        outline = np.column_stack([np.cos(angles), np.sin(angles)]) * rng.uniform(50, 200, (5, 1))
        polygon = np.column_stack([outline + objects[2].points[:, :2].mean(axis=0),
                                   np.full(5, objects[2].points[0, 2])])
        objects[2] = measure("polygon", polygon if rng.random() < 0.5 else polygon[::-1], objects[2].covariance,
                             id="3")
        features = {f["id"]: f for f in json.loads(geojson(objects, georeference))["features"]}
        for key in ("1", "2", "3", "4"):
            geometry = features[key]["geometry"]
            obj = next(o for o in objects if o.id == key)
            multi = geometry["type"].startswith("Multi")
            parts = geometry["coordinates"] if multi else [geometry["coordinates"]]
            crossing += multi
            for part in parts:
                lon = np.array(part[0] if key in ("3", "4") else part)[:, 0]
                assert lon.min() >= -180 and lon.max() <= 180
                assert lon.max() - lon.min() < 1.0, "a part jumps across the map"
            if key in ("1", "2"):
                length = sum(GEOD.line_length(*np.array(part).T[:2]) for part in parts)
                worst = max(worst, abs(length / obj.main.value - 1))
            else:
                areas = [GEOD.polygon_area_perimeter(*np.array(part[0]).T[:2])[0] for part in parts]
                assert min(areas) > 0
                expected = obj.figure("area").value if key == "3" else _shoelace(obj)
                worst = max(worst, abs(sum(areas) / expected - 1))
    assert crossing >= 20, crossing  # the test places most plots across the antimeridian
    assert worst < 1e-6, worst
