"""usvips render: the committed sample is reproduced exactly; bad scenes are refused naming the key."""

import json
from pathlib import Path

import numpy as np
import pytest

from usvips.cli import main
from usvips.core.targets import locate_disc
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
    assert len(committed) >= 10, "images, control, observations, truth and manifest"
    for relative in committed:
        assert (tmp_path / relative).read_bytes() == (sample / relative).read_bytes(), relative


def test_the_sample_opens_and_its_truth_matches_its_images():
    manifest = read_manifest(SAMPLE)
    assert manifest.housing == "flat-port" and len(manifest.pairs) == 3
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
])
def test_bad_scenes_are_refused_naming_the_key(tmp_path, capsys, edit, message):
    scene = json.loads((SAMPLE / "scene.json").read_text())
    scene["image"].update(width=160, height=120, supersample=1)
    edit(scene)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    assert main(["render", str(path), "--out", str(tmp_path / "out")]) == 2
    assert message in capsys.readouterr().err
