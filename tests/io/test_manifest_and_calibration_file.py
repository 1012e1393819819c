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
