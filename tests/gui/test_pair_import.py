"""Adding a dive's image pairs, the model without Qt: medium, prefix and edited labels, sizes and status,
unticked pairs left out, the good pairs added and the bad named (a second dive with the same names)."""

import numpy as np
import pytest

from usvips.gui.pair_import import OK, PairImport
from usvips.gui.wording import article, plural
from usvips.io.images import write_image
from usvips.store import Project


def dive(folder, names, sizes, right_sizes=None):
    """Left and right folders of GoPro-named PNGs; returns the plan (label, left, right)."""
    plan = []
    for side in ("left", "right"):
        (folder / side).mkdir(parents=True, exist_ok=True)
    for k, name in enumerate(names):
        paths = []
        for side, size in (("left", sizes[k]), ("right", (right_sizes or sizes)[k])):
            path = folder / side / f"{name}.png"
            write_image(path, np.full((size[1], size[0]), k * 10 % 255, np.uint8))
            paths.append(path)
        plan.append((name.lower(), *paths))
    return plan


@pytest.fixture
def project(tmp_path):
    with Project.create(tmp_path / "p.usvips") as project:
        yield project


def test_the_model_loads_no_qt():
    import subprocess
    import sys

    code = ("import sys, usvips.gui.pair_import;"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in {'PySide6', 'shiboken6', 'pyqtgraph'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("seed", range(5))
def test_a_second_dive_with_the_same_names_is_added_under_a_prefix_with_its_medium(project, tmp_path, seed):
    rng = np.random.default_rng(seed)
    count = int(rng.integers(2, 6))
    names = [f"GOPR{int(n):04d}" for n in rng.choice(9999, count, replace=False)]
    sizes = [(int(rng.integers(40, 90)), int(rng.integers(30, 70)))] * count
    first = PairImport(project, dive(tmp_path / "d1", names, sizes), "shared stem")
    added, left_out = first.add()
    assert added == [n.lower() for n in names] and left_out == []
    second = PairImport(project, dive(tmp_path / "d2", names, sizes), "shared stem")
    assert all(second.status(i).startswith("label already in the project") for i in range(count))
    assert second.good() == [] and len(second.bad()) == count
    second.set_prefix("dive2-")
    medium = str(rng.choice(["air", "water"]))
    second.set_medium(medium)
    assert [second.status(i) for i in range(count)] == [OK] * count
    assert second.size_text(0) == f"{sizes[0][0]} × {sizes[0][1]}"
    added, left_out = second.add()
    assert added == [f"dive2-{n.lower()}" for n in names] and left_out == []
    media = {p.label: p.medium for p in project.pairs()}
    assert all(media[label] == medium for label in added)
    assert all(media[n.lower()] == "water" for n in names)
    stored = {p.label: (p.width, p.height) for p in project.pairs()}
    assert all(stored[label] == sizes[0] for label in added)


@pytest.mark.parametrize("seed", range(5))
def test_edited_labels_unticked_and_misfit_pairs_the_good_ones_added_the_bad_named(project, tmp_path, seed):
    rng = np.random.default_rng(seed)
    count = int(rng.integers(4, 8))
    names = [f"IMG_{k:04d}" for k in range(count)]
    size = (int(rng.integers(40, 90)), int(rng.integers(30, 70)))
    sizes = [size] * count
    right_sizes = list(sizes)
    misfit = int(rng.integers(0, count))
    right_sizes[misfit] = (size[0] - 8, size[1] - 4)  # a cropped right image
    model = PairImport(project, dive(tmp_path, names, sizes, right_sizes), "shared stem", prefix="s-")
    seen = []
    model.changed.connect(lambda: seen.append(1))
    assert model.status(misfit) == f"left {size[0]} × {size[1]} px, right {size[0] - 8} × {size[1] - 4} px"
    assert model.size_text(misfit) == f"{size[0]} × {size[1]} | {size[0] - 8} × {size[1] - 4}"
    unticked = int(rng.choice([k for k in range(count) if k != misfit]))
    model.set_ticked(unticked, False)
    edited = int(rng.choice([k for k in range(count) if k not in (misfit, unticked)]))
    model.set_label(edited, "  the big one ")
    twice = [k for k in range(count) if k not in (misfit, unticked, edited)]
    if len(twice) >= 2:  # two pairs typed to one label: both named, neither added
        model.set_label(twice[0], "same")
        model.set_label(twice[1], "same")
        assert model.status(twice[0]) == model.status(twice[1]) == "label given twice"
        model.set_label(twice[1], "")  # back to the prefix and the label found
        assert model.label(twice[1]) == f"s-{names[twice[1]].lower()}" and model.status(twice[0]) == OK
    assert seen
    added, left_out = model.add()
    expected = [model.label(k) for k in range(count) if k not in (misfit, unticked)]
    assert added == expected and "the big one" in added
    assert left_out == [f"s-{names[misfit].lower()}: {model.status(misfit)}"]
    stored = [p.label for p in project.pairs()]
    assert stored == expected  # the unticked and the misfit are not in the project


def test_an_unreadable_file_is_named_and_the_rest_added(project, tmp_path):
    plan = dive(tmp_path, ["A1", "A2"], [(50, 40)] * 2)
    plan[1][1].write_bytes(b"not an image at all")
    model = PairImport(project, plan, "shared stem")
    assert model.status(1) == "the left image is not a readable image" and model.size_text(1) == "?"
    added, left_out = model.add()
    assert added == ["a1"] and left_out == ["a2: the left image is not a readable image"]


def test_plurals_and_articles():
    assert [plural(n, "pair") for n in (0, 1, 2)] == ["0 pairs", "1 pair", "2 pairs"]
    assert [plural(n, "vertex") for n in (1, 3)] == ["1 vertex", "3 vertices"]
    assert [article(k) for k in ("arc", "length", "object", "point")] == ["an arc", "a length", "an object",
                                                                           "a point"]
