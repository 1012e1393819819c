"""``usvips intersect`` read, intersected and written in chunks: the same rows however the file is cut
(chunks of any size, blocks of any byte count, comments, blank lines, quoted ids, CRLF), the same
one-line errors naming the first bad line even where it sits on a chunk's edge, and no output file (nor
a temporary one) left behind by a run that fails."""

import csv
import io

import numpy as np
import pytest

from usvips.app.intersect_file import FailedPointsError, IntersectOptions, intersect_file, point_rows, points_text
from usvips.bench.scaling import CALIBRATION, write_observations
from usvips.core.errors import InputFileError
from usvips.io.calibration_file import load_calibration
from usvips.io.observation_stream import SeenKeys, observation_chunks
from usvips.io.tables import read_observations, refuse_outside_image

WHOLE = 10**9  # rows per chunk: the whole file in one


@pytest.fixture(scope="module")
def calibration():
    return load_calibration(CALIBRATION)


@pytest.fixture
def observations(tmp_path, calibration):
    """40 points, with a comment, blank lines, a quoted id holding a comma and spaces around fields."""
    path = tmp_path / "obs.csv"
    write_observations(calibration, 40, path, seed=3)
    lines = path.read_text().splitlines()
    lines.insert(5, "# a comment between rows")
    lines.insert(9, "")
    lines[12] = '"fish, big",' + lines[12].split(",", 1)[1]
    lines[20] = lines[20].replace(",", " , ")
    path.write_text("\n".join(lines) + "\n")
    return path


def _run(calibration, obs, out, rows=WHOLE, **options):
    return intersect_file(calibration, obs, out, IntersectOptions(chunk_rows=rows, **options))


@pytest.mark.parametrize("rows", [1, 2, 3, 7, 16])
def test_chunked_and_whole_give_the_same_rows(tmp_path, calibration, observations, rows):
    whole = _run(calibration, observations, tmp_path / "whole.csv")
    chunked = _run(calibration, observations, tmp_path / "chunked.csv", rows)
    assert (tmp_path / "chunked.csv").read_bytes() == (tmp_path / "whole.csv").read_bytes()
    assert (whole.points, whole.written) == (chunked.points, chunked.written) == (40, 40)
    assert chunked.rms_px == pytest.approx(whole.rms_px, rel=1e-12)
    rows_read = list(csv.reader(io.StringIO((tmp_path / "chunked.csv").read_text())))
    assert rows_read[0] == ["id", "X", "Y", "Z", "sX", "sY", "sZ"] and len(rows_read) == 41
    assert "fish, big" in [row[0] for row in rows_read]  # written quoted, read back whole


def test_the_text_is_what_the_csv_module_writes(calibration, observations):
    from usvips.core.calibration.uncertainty import intersect_with_calibration

    read = read_observations(observations)
    result = intersect_with_calibration(calibration, read.left, read.right)
    result.status[[3, 17]] = 1  # two points that failed are left out
    for ids in (read.ids, tuple(f"q{i}" for i in range(len(read.ids)))):  # with and without an id to quote
        for pairs in (None, tuple(f"w{i % 3}" for i in range(len(ids))), tuple('w,"1"' for _ in ids)):
            buffer = io.StringIO()
            csv.writer(buffer, lineterminator="\n").writerows(point_rows(ids, result, pairs))
            assert points_text(ids, result, pairs) == buffer.getvalue()


@pytest.mark.parametrize("block_bytes", [1, 7, 64, 1 << 22])
def test_the_chunks_are_the_whole_files_rows(tmp_path, observations, block_bytes):
    crlf = tmp_path / "crlf.csv"
    crlf.write_bytes(b"\xef\xbb\xbf" + observations.read_bytes().replace(b"\n", b"\r\n"))
    whole = read_observations(observations)
    for path in (observations, crlf):
        chunks = list(observation_chunks(path, rows=3, block_bytes=block_bytes))
        assert all(0 < len(c) <= 3 for c in chunks)  # 3 lines each, blank and comment lines left out
        assert sum((c.ids for c in chunks), ()) == whole.ids
        assert sum((c.lines for c in chunks), ()) == whole.lines
        np.testing.assert_array_equal(np.concatenate([c.left for c in chunks]), whole.left)
        np.testing.assert_array_equal(np.concatenate([c.right for c in chunks]), whole.right)


BAD = {  # a bad line put at line 9 (data row 8): its error as the whole-file reader gives it
    "a word for a number": ("p7,12.5,abc,30,40", "column yl: 'abc' is not a number"),
    "a missing field": ("p7,12.5,20,30", "4 fields but the header has 5"),
    "an empty id": (",12.5,20,30,40", "empty id"),
    "an infinite number": ("p7,12.5,inf,30,40", "column yl: 'inf' is not a finite number"),
    "an unclosed quote": ('"p7,12.5,20,30,40', "not a valid CSV line"),
    "an id given twice": ("p2,12.5,20,30,40", "duplicate id 'p2' in pair '1' (first on line 4)"),
}


@pytest.mark.parametrize("case", sorted(BAD))
@pytest.mark.parametrize("rows", [1, 3, 7, 8, WHOLE])
def test_bad_input_on_a_chunks_edge_is_one_line_naming_it_and_writes_nothing(tmp_path, calibration, case, rows):
    """Rows 1-7 are good; line 9 (row 8) is bad: with chunks of 7 or 8 rows it is the first or the last row of
    a chunk."""
    good = [f"p{i},{100 + i},{200 + i},{90 + i},{200 + i}" for i in range(12)]
    bad_line, problem = BAD[case]
    lines = ["id,xl,yl,xr,yr", *good[:7], bad_line, *good[8:]]
    obs = tmp_path / "obs.csv"
    obs.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputFileError) as whole_error:
        read_observations(obs)
    out = tmp_path / "points.csv"
    with pytest.raises(InputFileError) as error:
        _run(calibration, obs, out, rows)
    assert error.value.line == 9 and problem in str(error.value) and str(error.value).startswith(f"{obs}, line 9: ")
    assert str(error.value) == str(whole_error.value) and "\n" not in str(error.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["obs.csv"]  # no output, no temporary file


@pytest.mark.parametrize("rows", [1, 4, WHOLE])
def test_pixels_outside_the_image_are_counted_over_the_whole_file(tmp_path, calibration, rows):
    good = [f"p{i},{100 + i},{200 + i},{90 + i},{200 + i}" for i in range(12)]
    good[3] = "p3,100,200,9000,200"  # right pixel outside
    good[9] = "p9,-40,200,90,200"  # left pixel outside: named first, as the whole-file check does
    good[10] = "p10,-41,200,90,200"
    obs = tmp_path / "obs.csv"
    obs.write_text("\n".join(["id,xl,yl,xr,yr", *good]) + "\n")
    read = read_observations(obs)
    with pytest.raises(InputFileError) as whole:
        refuse_outside_image(obs, list(read.ids), list(read.lines), read.left, read.right,
                             ((calibration.left.width, calibration.left.height),
                              (calibration.right.width, calibration.right.height)))
    with pytest.raises(InputFileError) as error:
        _run(calibration, obs, tmp_path / "points.csv", rows)
    assert str(error.value) == str(whole.value) and "2 such pixels in all" in str(error.value)
    assert not (tmp_path / "points.csv").exists()


def test_points_that_fail_stop_the_run_unless_left_out(tmp_path, calibration):
    obs = tmp_path / "obs.csv"
    write_observations(calibration, 10, obs, seed=4)
    lines = obs.read_text().splitlines()
    lines[6] = "p5,300,200,500,200"  # the right ray diverges from the left one (the right image sees it left)
    obs.write_text("\n".join(lines) + "\n")
    with pytest.raises(FailedPointsError) as error:
        _run(calibration, obs, tmp_path / "points.csv", 3)
    assert error.value.line == 7 and error.value.point == "p5" and (error.value.failed, error.value.total) == (1, 10)
    assert not (tmp_path / "points.csv").exists()
    summary = _run(calibration, obs, tmp_path / "points.csv", 3, skip_failed=True)
    assert summary.written == 9 and [point for point, _ in summary.skipped] == ["p5"]
    assert len((tmp_path / "points.csv").read_text().splitlines()) == 10


def test_the_hash_set_finds_exactly_the_keys_seen_before():
    rng = np.random.default_rng(5)
    seen, reference = SeenKeys(size=16), set()  # it grows many times
    seen.BATCH = 7  # and moves its keys a few at a time
    for _ in range(30):  # batches that repeat keys within themselves and across batches; 0 and -1 included
        keys = rng.integers(-50, 3000, rng.integers(1, 400))
        expected = []
        for k, key in enumerate(keys.tolist()):
            if (key or 1) in reference:
                expected.append(k)
            reference.add(key or 1)
        assert seen.add(keys).tolist() == expected


def _points(path):
    rows = list(csv.reader(io.StringIO(path.read_text())))
    return [row[0] for row in rows[1:]], np.array([[float(v) for v in row[1:]] for row in rows[1:]])


@pytest.mark.parametrize("seed", range(4))
def test_worker_processes_give_the_rows_of_this_process_alone(tmp_path, calibration, seed):
    """Random files, chunk sizes, options and points that do not intersect: the chunks worked on two
    processes give the rows, the summary and the failure of the same run in this process alone."""
    rng = np.random.default_rng(seed)
    obs = tmp_path / "obs.csv"
    count = int(rng.integers(30, 90))
    write_observations(calibration, count, obs, seed=seed + 20)
    lines = obs.read_text().splitlines()
    diverging = sorted(rng.choice(np.arange(1, count + 1), int(rng.integers(0, 3)), replace=False).tolist())
    for line in diverging:  # the right ray diverges from the left one (the right image sees it left)
        lines[line] = f"{lines[line].split(',')[0]},300,200,500,200"
    obs.write_text("\n".join(lines) + "\n")
    options = dict(chunk_rows=int(rng.integers(1, 12)), pointing_sigma_px=float(rng.uniform(0.2, 1.5)),
                   include_calibration=bool(rng.integers(0, 2)), frame=str(rng.choice(["object", "rig"])))
    for skip_failed in (False, True):
        outcomes = []
        for workers in (1, 2):
            out = tmp_path / f"points_{workers}.csv"
            try:
                outcomes.append(intersect_file(calibration, obs, out, IntersectOptions(
                    workers=workers, skip_failed=skip_failed, **options)))
            except FailedPointsError as error:
                outcomes.append((str(error), error.line))
                assert not out.exists()
        alone, pooled = outcomes
        if isinstance(alone, tuple):
            assert pooled == alone and alone[1] == diverging[0] + 1 and not skip_failed
            continue
        assert (pooled.points, pooled.written, pooled.skipped) == (alone.points, alone.written, alone.skipped)
        assert pooled.written == count - len(diverging)
        assert pooled.rms_px == pytest.approx(alone.rms_px, rel=1e-9)
        (ids_alone, numbers_alone), (ids_pooled, numbers_pooled) = (_points(tmp_path / f"points_{w}.csv")
                                                                    for w in (1, 2))
        assert ids_pooled == ids_alone and len(ids_alone) == pooled.written
        np.testing.assert_allclose(numbers_pooled, numbers_alone, rtol=1e-9, atol=2e-6)


@pytest.mark.parametrize("rows", [1, 4, WHOLE])
def test_a_mismatched_pair_is_counted_and_named_and_still_written(tmp_path, calibration, rows):
    """Noise of 0.3 px under a stated 0.5 px: no point misses (the limit is passed by chance once in ten
    thousand); a right pick moved 25 px across the epipolar curve is named with its line, however the file
    is cut into chunks, and the point is still written (the miss is reported, not hidden)."""
    obs = tmp_path / "obs.csv"
    write_observations(calibration, 12, obs, seed=6)
    clean = _run(calibration, obs, tmp_path / "clean.csv", rows, pointing_sigma_px=0.5)
    assert clean.misfits == 0 and clean.first_misfit is None
    lines = obs.read_text().splitlines()
    fields = lines[8].split(",")
    fields[4] = f"{float(fields[4]) + 25:.4f}"  # yr: across the epipolar curve of a near-horizontal rig
    lines[8] = ",".join(fields)
    obs.write_text("\n".join(lines) + "\n")
    summary = _run(calibration, obs, tmp_path / "points.csv", rows, pointing_sigma_px=0.5)
    assert summary.written == 12 and summary.misfits == 1
    first = summary.first_misfit
    assert (first.point, first.line) == (fields[0], 9) and first.misfit > first.limit
    assert first.rms_px > 3


def test_each_row_is_intersected_at_the_station_its_pair_column_names(tmp_path):
    """A calibration of two stations (water1, water2) and one observation file of both pairs: each row at
    its own pair's station lands on its control point (the sample's truth), chunked or whole, and the
    output names each row's pair (an id repeats across pairs). A row of another calibrated station than
    the one given is refused by its line; a pair that is no calibrated station goes to the first station,
    and the run says which pairs did; in the rig frame the station does not matter."""
    from pathlib import Path

    from usvips.io.tables import read_control

    sample = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport"
    calibration = load_calibration(sample / "calibration.json")
    assert calibration.stations == ("water1", "water2")
    observed = sample / "observations_water.csv"
    control = read_control(sample / "control.csv")
    truth = dict(zip(control.ids, control.xyz, strict=True))
    texts = []
    for rows in (WHOLE, 3):
        _run(calibration, observed, tmp_path / "points.csv", rows)
        texts.append((tmp_path / "points.csv").read_text())
    assert texts[0] == texts[1]
    table = list(csv.reader(io.StringIO(texts[0])))
    assert table[0] == ["id", "X", "Y", "Z", "sX", "sY", "sZ", "pair"]  # (the columns keep their places)
    pairs = {row[7] for row in table[1:]}
    assert pairs == {"water1", "water2"}
    z = np.array([(np.array(row[1:4], float) - truth[row[0]]) / np.array(row[4:7], float) for row in table[1:]])
    assert np.all(np.abs(z) < 5) and 0.05 < np.mean(z ** 2) < 3
    with pytest.raises(InputFileError, match=r"line \d+: pair 'water2' is calibrated station 1 \(water2\), not the "
                                             r"station given \(water1\)"):
        _run(calibration, observed, tmp_path / "one.csv", station="water1")
    assert not (tmp_path / "one.csv").exists()
    renamed = tmp_path / "renamed.csv"
    renamed.write_text(observed.read_text().replace("water2", "nosuch"))
    assert _run(calibration, renamed, tmp_path / "two.csv").unplaced == ["nosuch"]  # the first station's, said
    assert _run(calibration, observed, tmp_path / "two.csv").unplaced == []
    rig = _run(calibration, renamed, tmp_path / "rig.csv", frame="rig")
    assert rig.written == len(table) - 1 and rig.unplaced == []
    # the water2 rows put in water1's frame (what one station for every row did) miss their points
    wrong = _run(calibration, renamed, tmp_path / "wrong.csv", station="water1")
    rows = [row for row in csv.reader(io.StringIO((tmp_path / "wrong.csv").read_text())) if row[7] == "nosuch"]
    assert wrong.written == len(table) - 1 and rows
    assert np.median([np.linalg.norm(np.array(row[1:4], float) - truth[row[0]]) for row in rows]) > 0.05


def test_a_pixel_the_lens_distortion_cannot_undo_is_one_failed_point_named_by_its_line(tmp_path, calibration):
    """A calibration whose distortion folds over before the image's corner: a pick there has no ray. It is
    that point that fails, named by its line and why (not the whole run, unnamed), and --skip-failed
    writes the others."""
    import dataclasses

    obs = tmp_path / "obs.csv"
    write_observations(calibration, 12, obs, seed=5)
    lines = obs.read_text().splitlines()
    interior = calibration.left.interior
    corner = np.hypot(*interior.pixels_to_image(np.array([[0.0, 0.0]]))[0]) / interior.f  # normalised radius
    # r + k2 r⁵ is largest, 0.8 r0, at r0 = (−1 / 5 k2)^¼: no ray for a pick beyond 0.97 of the corner's radius
    fold = 0.97 * corner / 0.8
    folding = interior.with_values(k1=0.0, k2=-1.0 / (5 * fold ** 4), k3=0.0, p1=0.0, p2=0.0)
    left = dataclasses.replace(calibration.left, interior=folding)
    folded = dataclasses.replace(calibration, left=left, covariance=None, parameters={})
    good = _run(folded, obs, tmp_path / "first.csv", frame="rig", skip_failed=True)
    assert not [why for _, why in good.skipped if "distortion" in why]
    fields = lines[7].split(",")
    lines[7] = ",".join([fields[0], "0.5", "0.5", *fields[3:]])  # the left pick in the image's corner
    obs.write_text("\n".join(lines) + "\n")
    with pytest.raises(FailedPointsError, match=rf"obs.csv, line 8: point '{fields[0]}': the calibration's lens "
                                                "distortion cannot be undone at this pixel"):
        _run(folded, obs, tmp_path / "points.csv", frame="rig")
    assert not (tmp_path / "points.csv").exists()
    summary = _run(folded, obs, tmp_path / "points.csv", frame="rig", skip_failed=True, rows=5)
    assert summary.written == good.written - 1
    assert [point for point, _ in summary.skipped if "distortion" in _] == [fields[0]]
