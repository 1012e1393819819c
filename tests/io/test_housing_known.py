"""Known housing values in a manifest (``housing_known``) and a scene (``housing.known``): names checked
against the housing kind's parameters (the registry), values a number (fixed) or [value, sigma]."""

from __future__ import annotations

import json

import pytest

from usvips.core.errors import InputFileError
from usvips.io.manifest import read_manifest, split_known
from usvips.io.scene import read_scene
from usvips.locations import sample_project


def _manifest(tmp_path, **extra):
    data = {"format": "usvips-sample", "version": 1, "name": "known", "pairs": [], "observations": [], **extra}
    (tmp_path / "project.json").write_text(json.dumps(data))
    return tmp_path / "project.json"


def test_known_values_are_read_by_the_kinds_names(tmp_path):
    manifest = read_manifest(_manifest(tmp_path, housing="flat-port",
                                       housing_known={"t": 0.016, "n2": [1.65, 0.01], "g_l": 0.08}))
    assert manifest.housing_known == {"t": (0.016, None), "n2": (1.65, 0.01), "g_l": (0.08, None)}
    assert split_known(manifest.housing_known) == ({"t": 0.016, "g_l": 0.08}, {"n2": (1.65, 0.01)})
    dome = read_manifest(_manifest(tmp_path, housing="dome-port", housing_known={"r": 0.05, "dz_r": [0, 0.002]}))
    assert dome.housing_known == {"r": (0.05, None), "dz_r": (0.0, 0.002)}


@pytest.mark.parametrize(("extra", "message"), [
    ({"housing": "flat-port", "housing_known": {"r": 0.05}},
     "housing_known.r: not a parameter of the flat-port housing; parameters: d, d_l, d_r, e, e_l, e_r, g, g_l, g_r"),
    ({"housing": "dome-port", "housing_known": {"g": 0.05}}, "housing_known.g: not a parameter of the dome-port"),
    ({"housing": "air", "housing_known": {"t": 0.01}}, "not a parameter of the air housing; parameters: none"),
    ({"housing_known": {"t": 0.01}}, "housing_known: give the housing kind the values belong to"),
    ({"housing": "flat-port", "housing_known": {"t": "thick"}}, "housing_known.t: expected a number or [value, sigma"),
    ({"housing": "flat-port", "housing_known": {"t": [0.01, 0]}}, "housing_known.t: expected a number or"),
    ({"housing": "flat-port", "housing_known": {"t": float("nan")}}, "housing_known.t: expected a number"),
    ({"housing": "flat-port", "housing_known": [0.01]}, "housing_known: expected an object"),
    ({"housing": "bathyscaphe"}, "key 'housing': must be one of air, flat-port, dome-cover, dome-port"),
])
def test_bad_known_values_are_one_line_naming_the_key(tmp_path, extra, message):
    with pytest.raises(InputFileError) as caught:
        read_manifest(_manifest(tmp_path, **extra))
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_a_scene_states_its_known_values_and_bad_ones_are_refused(tmp_path):
    scene = json.loads((sample_project("rov_flatport") / "scene.json").read_text())
    assert read_scene(sample_project("rov_flatport") / "scene.json").housing_known == {"t": (0.016, None),
                                                                                        "n2": (1.65, None)}
    scene["housing"]["known"] = {"q": 1.0}
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    with pytest.raises(InputFileError, match=r"housing\.known\.q: not a parameter of the flat-port housing"):
        read_scene(path)
