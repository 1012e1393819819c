import json
from pathlib import Path

import pytest

from usvips.core.errors import InputFileError
from usvips.io.calibration_file import load_calibration
from usvips.io.manifest import read_manifest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_projects" / "tank_1995"


def test_the_sample_manifest_reads():
    manifest = read_manifest(SAMPLE)
    assert manifest.name == "tank_1995" and manifest.housing == "dome-cover"
    assert [e.role for e in manifest.observations].count("check") == 2
    assert all(e.file.exists() for e in manifest.observations)


@pytest.mark.parametrize("data, message", [
    ({"format": "other"}, "not a USVIPS sample manifest"),
    ({"format": "usvips-sample", "version": 9, "name": "x"}, "version 9 is not supported"),
    ({"format": "usvips-sample", "version": 1, "name": "x", "colour": 1}, "unknown key(s) 'colour'"),
    ({"format": "usvips-sample", "version": 1, "name": "x", "control": "../etc/passwd"}, "outside the project"),
    ({"format": "usvips-sample", "version": 1, "name": "x", "control": "missing.csv"}, "does not exist"),
    ({"format": "usvips-sample", "version": 1, "name": "x", "housing": "bubble"}, "key 'housing'"),
])
def test_bad_manifests_name_the_key(tmp_path, data, message):
    (tmp_path / "project.json").write_text(json.dumps(data))
    with pytest.raises(InputFileError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_manifest(tmp_path)


@pytest.mark.parametrize("text, message", [
    ("{not json", "not valid JSON"),
    (json.dumps({"format": "usvips-calibration", "version": 99}), "newer than this USVIPS reads"),
    (json.dumps({"format": "usvips-calibration", "version": 1}), "missing key 'housing'"),
    (json.dumps({"format": "x"}), "not a USVIPS calibration file"),
])
def test_bad_calibration_files_are_refused(tmp_path, text, message):
    path = tmp_path / "cal.json"
    path.write_text(text)
    with pytest.raises(InputFileError, match=message):
        load_calibration(path)


CALIBRATION = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport" / "calibration.json"


def _negative_eigenvalue(data):
    names = data["covariance"]["names"][:2]
    data["covariance"] = {"names": names, "matrix": [[1.0, 2.0], [2.0, 1.0]]}   # eigenvalues 3 and -1


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(version=0), "version: must be a whole number from 1"),
    (lambda d: d.update(version=True), "version: must be a whole number from 1"),
    (lambda d: d["cameras"]["left"].update(width=-640), "cameras.left.width: must be a positive whole number"),
    (lambda d: d["cameras"]["right"].update(height=480.5), "cameras.right.height"),
    (lambda d: d.update(parameters=[1, 2]), "parameters: must be an object"),
    (lambda d: d.update(parameters={"f_l": {"value": "700"}}), "parameters.f_l.value: must be a finite number"),
    (lambda d: d.update(parameters={"f_l": {"value": 700, "sigma": -1}}), "parameters.f_l.sigma"),
    (lambda d: d.update(parameters={"f_l": {"value": 700, "status": "maybe"}}), "parameters.f_l.status"),
    (lambda d: d.update(covariance="none"), "covariance: must be an object"),
    (lambda d: d["covariance"].update(matrix=[[1]]), "covariance.matrix: must be"),
    (lambda d: d["covariance"]["matrix"][0].__setitem__(0, -1e-3), "negative variance"),
    (_negative_eigenvalue, "not positive semi-definite"),
    (lambda d: d.update(sigma0_px=-0.5), "sigma0_px: must be >= 0"),
    (lambda d: d.update(statistics=[1]), "statistics: must be an object"),
    (lambda d: d["parameters"].pop("X0_l"), "parameters: missing X0_l"),
    (lambda d: d["cameras"]["right"]["housing"].update(d=1e300),
     "cameras.right.housing.d: 1e"),
    (lambda d: d["covariance"]["names"].__setitem__(0, "q_l"), "covariance: names q_l, which are not in parameters"),
    (lambda d: d["parameters"].pop([n for n in d["parameters"] if n.startswith("kappa_r")][0]),
     "parameters: missing kappa_r"),
    (lambda d: d["stations"][0].update(label=[1]), "label must be a name or a number, got list"),
    (lambda d: d["stations"][0].update(label=" "), 'label must be a name or a number, got " "'),
    (lambda d: d["stations"].append(dict(d["stations"][0])), "is the label of stations"),
    # a misspelt or unknown key would be dropped silently (a misspelt covariance: every sigma without the
    # calibration's own uncertainty)
    (lambda d: d.update(covarience=d.pop("covariance")), "calibration.covarience: not a key of a calibration file"),
    (lambda d: d["cameras"]["left"].update(widht=640), "cameras.left.widht: not a key of a camera"),
    (lambda d: d["cameras"].update(middle={}), "cameras.middle: not a camera"),
    (lambda d: d["stations"][0].update(Z=1.0), "0].Z: not a key of a station"),
    # a missing interior term or housing value would be read as its default (sy 1, k1 0, n2 …), silently
    (lambda d: [d.pop("parameters"), d.pop("covariance"), d["cameras"]["left"]["interior"].pop("sy")],
     "left interior: missing parameter 'sy'"),
    (lambda d: [d.pop("parameters"), d.pop("covariance"), d["cameras"]["right"]["interior"].pop("k1")],
     "right interior: missing parameter 'k1'"),
    (lambda d: [d.pop("parameters"), d.pop("covariance"), d["cameras"]["left"]["housing"].pop("n2")],
     "cameras.left.housing: missing parameter 'n2'"),
])
def test_calibration_values_are_checked_by_name(tmp_path, edit, message):
    data = json.loads(CALIBRATION.read_text())
    edit(data)
    path = tmp_path / "c.json"
    path.write_text(json.dumps(data))
    with pytest.raises(InputFileError, match=message.replace("(", r"\(").replace(".", r"\.")):
        load_calibration(path)


def test_a_deeply_nested_calibration_is_one_error(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InputFileError, match="nested too deeply|not a USVIPS calibration"):
        load_calibration(path)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["observations"][0].update(pairs="air1"), "observations.pairs: expected a list"),
    (lambda d: d["observations"][0].update(pairs=["nope"]), "no pair labelled 'nope'"),
    (lambda d: d["calibrations"][0].update(active_for=[1]), "calibrations.active_for"),
    (lambda d: d["pairs"][0].update(medium=["air"]), "medium must be one of"),
    (lambda d: d.update(control="a\x00b"), "not a usable file path"),
    (lambda d: d.update(description=5), "key 'description'"),
])
def test_manifest_values_are_checked_by_name(tmp_path, edit, message):
    import shutil

    sample = tmp_path / "rov"
    shutil.copytree(CALIBRATION.parent, sample, ignore=shutil.ignore_patterns("project.usvips*", "*.avi",
                                                                              "images"))
    shutil.copytree(CALIBRATION.parent / "images", sample / "images")
    data = json.loads((sample / "project.json").read_text())
    data.pop("video")                                   # the videos are not copied
    edit(data)
    (sample / "project.json").write_text(json.dumps(data))
    with pytest.raises(InputFileError, match=message):
        read_manifest(sample)


def test_k3_bumps_the_file_version_so_an_older_usvips_refuses_rather_than_drops_it(tmp_path, monkeypatch):
    """k3 = 0 keeps version 1 (every USVIPS reads it); k3 ≠ 0 is version 2, which a reader of version 1
    refuses by name; both load here with every interior value."""
    from dataclasses import replace

    from usvips.io import calibration_file
    from usvips.io.calibration_file import calibration_to_dict, save_calibration

    plain = load_calibration(SAMPLE.parent / "rov_flatport" / "calibration.json")
    assert plain.left.interior.k3 == 0 and plain.right.interior.k3 == 0
    assert calibration_to_dict(plain)["version"] == 1
    for side, k3 in (("left", 0.012), ("right", -3e-4)):
        camera = getattr(plain, side)
        key = f"k3_{side[0]}"
        parameters = {**plain.parameters, key: replace(plain.parameters[key], value=k3)}
        bent = replace(plain, parameters=parameters,
                       **{side: replace(camera, interior=replace(camera.interior, k3=k3))})
        assert calibration_to_dict(bent)["version"] == 2
        save_calibration(bent, tmp_path / f"{side}.json")
        again = load_calibration(tmp_path / f"{side}.json")
        assert getattr(again, side).interior.k3 == k3 and getattr(again, side).interior.f == camera.interior.f
        monkeypatch.setattr(calibration_file, "VERSION", 1)  # a USVIPS from before k3
        with pytest.raises(InputFileError, match="version 2 is newer than this USVIPS reads"):
            load_calibration(tmp_path / f"{side}.json")
        monkeypatch.undo()
    save_calibration(plain, tmp_path / "plain.json")
    assert json.loads((tmp_path / "plain.json").read_text())["version"] == 1
    monkeypatch.setattr(calibration_file, "VERSION", 1)
    assert load_calibration(tmp_path / "plain.json").left.interior.f == plain.left.interior.f
