"""usvips render: the committed sample is reproduced exactly; bad scenes are refused naming the key."""

import json
from pathlib import Path

import numpy as np
import pytest

from usvips.cli import main
from usvips.core.calibration.uncertainty import joint_covariance
from usvips.core.measure import fish_length
from usvips.core.targets import locate_disc
from usvips.io.calibration_file import load_calibration
from usvips.io.images import read_image
from usvips.io.manifest import read_manifest

SAMPLES = Path(__file__).resolve().parents[2] / "sample_projects"
SAMPLE = SAMPLES / "rov_flatport"


@pytest.mark.parametrize("name", ["rov_flatport", "tank_system1"])
def test_the_committed_samples_are_reproduced_byte_for_byte(tmp_path, name):
    sample = SAMPLES / name
    assert main(["render", str(sample / "scene.json"), "--out", str(tmp_path)]) == 0
    committed = sorted(p.relative_to(sample) for p in sample.rglob("*") if p.is_file()
                       and p.name not in ("scene.json", "README.md")
                       and not p.name.startswith("project.usvips"))
    assert len(committed) >= 14, "images, control, observations, calibrations, truth and manifest"
    for relative in committed:
        if relative.name.startswith("calibration"):
            # An adjustment's last digits depend on the BLAS and OpenCV build: compare what matters.
            _assert_same_calibration(load_calibration(tmp_path / relative), load_calibration(sample / relative))
        elif relative.name == "truth.json":
            # true pixels and points move in their last bits with the arithmetic (compiled kernels, BLAS)
            _assert_same_numbers(json.loads((tmp_path / relative).read_text()),
                                 json.loads((sample / relative).read_text()), str(relative))
        else:
            assert (tmp_path / relative).read_bytes() == (sample / relative).read_bytes(), relative


def _assert_same_numbers(fresh, committed, where: str) -> None:
    """The same JSON structure and text, and the same numbers to 1e-9 (relative or absolute)."""
    assert type(fresh) is type(committed), where
    if isinstance(committed, dict):
        assert fresh.keys() == committed.keys(), where
        for key in committed:
            _assert_same_numbers(fresh[key], committed[key], f"{where}/{key}")
    elif isinstance(committed, list):
        assert len(fresh) == len(committed), where
        for i, (a, b) in enumerate(zip(fresh, committed, strict=True)):
            _assert_same_numbers(a, b, f"{where}/{i}")
    elif isinstance(committed, float):
        assert fresh == pytest.approx(committed, rel=1e-9, abs=1e-9), where
    else:
        assert fresh == committed, where


def _assert_same_calibration(fresh, committed) -> None:
    """The same calibration up to rounding: the same structure and statuses, every estimated parameter
    within a thousandth of its sigma, sigmas within 0.1 %, and the same pixels (to a thousandth of the
    pointing sigma sigma0; an adjustment stops when its steps fall below a small fraction of the sigmas,
    so another BLAS or another derivative route ends a few 1e-6 px away) for points spread over both
    cameras' views at every station."""
    assert (fresh.phase, fresh.stations, fresh.left.housing.kind) == (committed.phase, committed.stations,
                                                                      committed.left.housing.kind)
    assert fresh.parameters.keys() == committed.parameters.keys()
    for name, expected in committed.parameters.items():
        got = fresh.parameters[name]
        assert got.status == expected.status, name
        if expected.sigma is not None:
            assert got.sigma == pytest.approx(expected.sigma, rel=1e-3), name
            assert abs(got.value - expected.value) <= 1e-3 * expected.sigma, name
        else:
            assert got.value == pytest.approx(expected.value, rel=1e-6, abs=1e-9), name
    assert fresh.sigma0_px == pytest.approx(committed.sigma0_px, rel=1e-4)
    for key in ("redundancy", "excluded", "converged"):
        assert fresh.statistics.get(key) == committed.statistics.get(key), key
    for station in committed.stations:
        rig = committed.rig(station)
        left = rig.left
        grid = np.stack(np.meshgrid(np.linspace(0.15, 0.85, 5) * left.width,
                                    np.linspace(0.15, 0.85, 5) * left.height), -1).reshape(-1, 2)
        for depth in (1.5, 3.0, 6.0):
            rays = left.rays(grid)
            points = rays.origins + depth * rays.directions
            for side in ("left", "right"):
                expected = getattr(rig, side).project(points)
                got = getattr(fresh.rig(station), side).project(points)
                ok = expected.status == 0
                assert ok.sum() >= 5 and np.array_equal(got.status == 0, ok), (station, side, depth)
                np.testing.assert_allclose(got.pixels[ok], expected.pixels[ok], rtol=0,
                                           atol=1e-3 * committed.sigma0_px,
                                           err_msg=f"{station} {side} at {depth} m")


@pytest.mark.parametrize("name", ["rov_flatport", "tank_system1"])
def test_the_rendered_fish_measure_their_true_length_within_their_sigma(name):
    """Truth pixels of snout and fork, intersected with the sample's own (estimated) calibration in the
    rig frame: each fork length is within 3 sigma of the truth (pointing + calibration covariance), and
    the sigmas are not absurdly generous (the errors are not all below a tenth of a sigma)."""
    sample = SAMPLES / name
    calibration = load_calibration(sample / "calibration.json")
    truth = json.loads((sample / "truth.json").read_text())
    pair = next(p for p in truth["pairs"] if p["label"] == "measure1")
    z = []
    for fish in (o for o in truth["objects"] if o["kind"] == "fish"):
        left = np.array([pair["cameras"]["left"]["objects"][fish["label"]][k] for k in ("snout", "fork")])
        right = np.array([pair["cameras"]["right"]["objects"][fish["label"]][k] for k in ("snout", "fork")])
        result, covariance = joint_covariance(calibration, left, right, 0, "rig")
        length = fish_length(result.points[0], result.points[1], covariance)
        assert length.sigma > 0
        points = fish["points"]
        assert abs(fish["length"] - np.linalg.norm(np.subtract(points["fork"], points["snout"]))) < 1e-12
        z.append((length.value - fish["length"]) / length.sigma)
    assert len(z) == 2
    assert np.all(np.abs(z) < 3), z
    assert np.max(np.abs(z)) > 0.1, z


def test_the_sample_opens_and_its_truth_matches_its_images():
    manifest = read_manifest(SAMPLE)
    assert manifest.housing == "flat-port" and [p.label for p in manifest.pairs] == ["air1", "water1", "water2",
                                                                                    "measure1"]
    assert [c.active_for for c in manifest.calibrations] == [("air1",), ("water1", "water2", "measure1")]
    measure = read_image(SAMPLE / "images" / "measure1_left.png")
    assert measure.ndim == 3 and measure.shape[2] == 3, "the ROV sample's measurement pair is in colour"
    truth = json.loads((SAMPLE / "truth.json").read_text())
    pair = truth["pairs"][1]
    image = read_image(SAMPLE / "images" / f"{pair['label']}_left.png")
    errors = []
    for pixel in [p for p in pair["cameras"]["left"]["targets"].values() if p is not None]:
        x, y = pixel
        if 25 < x < image.shape[1] - 25 and 25 < y < image.shape[0] - 25:
            found = locate_disc(image, (x, y), window=41)
            if found:  # targets crowding each other in the window are refused, rightly
                errors.append(np.hypot(found.center[0] - x, found.center[1] - y))
    assert len(errors) >= 6 and max(errors) < 0.2  # noisy, blurred, hazy rendering


@pytest.mark.parametrize("edit, message", [
    (lambda s: s.update(colour=1), "unknown key 'colour'"),
    (lambda s: s.pop("relative"), "missing key 'relative'"),
    (lambda s: s["housing"].update(kind="bubble"), "housing.kind"),
    (lambda s: s["pairs"][0]["pose"].update(Z0=-101.5), "targets are seen by both cameras"),
    (lambda s: s["objects"][0].update(tail=1), "objects[0]: unknown key 'tail'"),
    (lambda s: s["objects"][0].pop("fork"), "objects[0]: missing key 'fork'"),
    (lambda s: s["objects"][1].update(kind="shark"), "objects[1].kind"),
    (lambda s: s["objects"][0].update(fork=s["objects"][0]["snout"]), "fish fork"),
    (lambda s: s["pairs"][3].update(contents=["fish"]), "pairs[3].contents: unknown 'fish'"),
    (lambda s: (s.update(pairs=s["pairs"][3:]), s["pairs"][0]["pose"].update(Z0=-101.5)), "object 'fish1' is not seen"),
    (lambda s: s["video"].update(speed=1), "video: unknown key 'speed'"),
    (lambda s: s["video"].pop("fps"), "video: missing key 'fps'"),
    (lambda s: s["video"].update(pair="nope"), "video.pair: no pair labelled 'nope'"),
    (lambda s: s["video"].update(pair="water1"), "does not show the objects"),
    (lambda s: s["video"].update(object="shark"), "video.object: no object labelled 'shark'"),
    (lambda s: s["video"].update(fps=12.5), "video.fps"),
    (lambda s: s["video"].update(frame_offset=30), "video.frame_offset"),
    (lambda s: s["video"].update(velocity=[1, 2]), "video.velocity"),
    (lambda s: s["image"].update(width="64"), "image.width: must be a whole number"),
    (lambda s: s["image"].update(supersample=0), "image.supersample: must be in [1, 8]"),
    (lambda s: s["image"].update(height=64.5), "image.height: must be a whole number"),
    (lambda s: s["housing"].pop("left"), "housing.left: expected an object"),
    (lambda s: s["water"].update(attenuation=-0.1), "water.attenuation: must be in [0"),
    (lambda s: s["floor"].update(cell=0), "floor.cell: must be in"),
    (lambda s: s.update(seed=[[[[1]]]]), "seed: must be a whole number"),
    (lambda s: s["pairs"][0].update(label="../escape"), "pairs[0].label: must be a plain name"),
    (lambda s: s["pairs"][1].update(label=s["pairs"][0]["label"]), "pairs[1].label: 'air1' is used twice"),
    (lambda s: s["frame"].update(targets="/etc/passwd"), "frame.targets: must be a plain .csv file name"),
    (lambda s: s["frame"].update(targets="../control.csv"), "frame.targets: must be a plain .csv file name"),
    (lambda s: s["objects"][0].update(kind=["fish"]), "objects[0].kind"),
    (lambda s: s["left"].update(f=0), "left.f: must be in (0"),
    (lambda s: s["image"].update(width=16384, height=16384, supersample=8), "image: width × height × supersample²"),
])
def test_bad_scenes_are_refused_naming_the_key(tmp_path, capsys, edit, message):
    scene = json.loads((SAMPLE / "scene.json").read_text())
    scene["image"].update(width=160, height=120, supersample=1)
    edit(scene)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    assert main(["render", str(path), "--out", str(tmp_path / "out")]) == 2
    assert message in capsys.readouterr().err


def test_the_sample_video_has_its_frame_offset_where_the_truth_says():
    """Each left frame's fish snout is matched along its refractive epipolar curve into right frames
    with trial offsets: only the true offset puts the match on the curve (the fish also moves across it)."""
    from usvips.core.matching import epipolar_curve, match_along_curve
    from usvips.io.video import read_frames, video_info

    manifest = read_manifest(SAMPLE)
    truth = json.loads((SAMPLE / "truth.json").read_text())["video"]
    offset = manifest.video.frame_offset
    assert offset == truth["frame_offset"] == 3
    info = video_info(manifest.video.right)
    assert (info.frames, info.fps, info.width, info.height) == (30, 10.0, 640, 480)
    left, right = list(read_frames(manifest.video.left)), list(read_frames(manifest.video.right))
    rig = load_calibration(SAMPLE / "calibration.json").rig(0, "rig")
    off_curve = {}
    for trial in range(-2, 8):
        distances = []
        for i in range(0, 30, 2):
            if not 0 <= i + trial < 30:
                continue
            snout = truth["left"][i]["pixels"]["snout"]
            curve = epipolar_curve(rig.left, rig.right, snout, 0.3, 10.0, samples=400)
            match = match_along_curve(left[i], right[i + trial], snout, curve, window=21)
            if match.pixel is not None:
                distances.append(curve.distance_to(np.array(match.pixel)))
        off_curve[trial] = float(np.mean(distances))
    assert min(off_curve, key=off_curve.get) == offset
    assert off_curve[offset] < 0.5 and all(v > 1.0 for k, v in off_curve.items() if k != offset)


def test_the_video_truth_pairs_frames_at_the_same_instant():
    """Truth pixels of left frame i and right frame i + offset intersect to the fish's true snout and fork."""
    truth = json.loads((SAMPLE / "truth.json").read_text())["video"]
    offset = truth["frame_offset"]
    rig = load_calibration(SAMPLE / "calibration.json").rig(0, "rig")
    fish = next(o for o in json.loads((SAMPLE / "truth.json").read_text())["objects"] if o["label"] == truth["object"])
    for i in (0, 10, 26):
        left, right = truth["left"][i], truth["right"][i + offset]
        assert left["time_s"] == pytest.approx(right["time_s"]) == pytest.approx(i / truth["fps"])
        assert left["points"] == right["points"]
        moved = np.subtract(left["points"]["snout"], fish["points"]["snout"])
        assert moved == pytest.approx(np.multiply(truth["velocity"], i / truth["fps"]))
        from usvips.core.intersection import intersect

        pixels = [np.array([left["pixels"][p] for p in ("snout", "fork")]),
                  np.array([right["pixels"][p] for p in ("snout", "fork")])]
        points = intersect(rig.cameras, pixels, 0.3).require_ok().points
        assert np.linalg.norm(points[1] - points[0]) == pytest.approx(fish["length"], abs=0.01)


def test_render_is_all_or_nothing_and_stays_inside_out(tmp_path, capsys):
    """A pair that fails late leaves neither the earlier pairs' images nor anything else in --out, and
    nothing is written beside it."""
    scene = json.loads((SAMPLE / "scene.json").read_text())
    scene["image"].update(width=96, height=72, supersample=1)
    scene.pop("video")
    scene["pairs"][-1]["pose"].update(Z0=-101.5)          # the last pair fails after the others were drawn
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["render", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "scene.json"]


def test_a_scene_that_names_another_file_reads_nothing_and_echoes_nothing(tmp_path, capsys):
    secret = tmp_path / "secret.csv"
    secret.write_text("id,X,Y,Z\ntop-secret-line-of-a-private-file,1,2,3,4\n")
    scene = json.loads((SAMPLE / "scene.json").read_text())
    scene["frame"]["targets"] = "secret.csv"
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    assert main(["render", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "top-secret" not in err and err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_render_to_a_file_is_refused(tmp_path, capsys):
    target = tmp_path / "a_file"
    target.write_text("x")
    assert main(["render", str(SAMPLE / "scene.json"), "--out", str(target)]) == 2
    assert "must be a folder" in capsys.readouterr().err and target.read_text() == "x"
