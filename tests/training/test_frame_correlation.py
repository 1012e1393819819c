"""The [frame_correlation] table measured by usvips.training.frame_correlation: a run's lengths grouped by
fish, the table written is the table read back, and bad runs are refused in one line without writing. (The
estimator itself is tested over many random cases in tests/core/test_instants.py; the shipped value on
held-out clips by tests/app/test_detection_acceptance.py.)"""

import numpy as np
import pytest

from tests.training.test_stereo_sigma import DESCRIPTION
from usvips.app.detection_acceptance import AcceptanceFigures
from usvips.core.measurements.instants import frame_correlation
from usvips.io.model_description import read_model_description
from usvips.training.frame_correlation import fish_errors, frame_correlation_table, main


def test_a_runs_lengths_are_grouped_by_fish_and_give_their_correlation():
    rng = np.random.default_rng(4)
    figures = AcceptanceFigures()
    truth = {}
    for clip in range(1, 25):
        for fish in range(3):
            truth[(clip, fish)] = rng.normal()
    for _frame in range(4):  # the run's order: frame by frame, fish by fish
        for (clip, fish), shared in truth.items():
            if rng.random() < 0.8:
                figures.fish.append((clip, fish))
                figures.single.append(float(np.sqrt(0.5) * shared + np.sqrt(0.5) * rng.normal()))
    groups = fish_errors(figures)
    assert sum(len(g) for g in groups) == len(figures.single) and len(groups) <= len(truth)
    first = figures.fish[0]
    assert groups[0] == [z for f, z in zip(figures.fish, figures.single, strict=True) if f == first]
    found = frame_correlation(groups)
    assert abs(found.value - 0.5) < 4 * found.uncertainty


def test_the_table_written_is_the_one_read_back(tmp_path):
    groups = [np.full(3, z) + 0.3 * np.random.default_rng(i).normal(size=3)
              for i, z in enumerate(np.random.default_rng(1).normal(size=20))]
    found = frame_correlation(groups)
    path = tmp_path / "fish.toml"
    path.write_text(DESCRIPTION + frame_correlation_table(found, '20 "fish"'))
    description = read_model_description(path)
    assert description.frame_correlation == pytest.approx(found.value, abs=1e-4)
    assert description.frame_correlation_basis == '20 "fish"'


@pytest.mark.parametrize("arguments, words", [
    (["--seeds", "1", "1", "--out", "{model}"], "would write over"),
    (["--seeds", "1", "0", "--out", "{out}"], "COUNT must be >= 1"),
    (["--seeds", "1", "1", "--frames", "1", "--out", "{out}"], "--frames: a fish must be seen on 2 frames"),
])
def test_a_bad_run_is_refused_in_one_line_and_writes_nothing(tmp_path, capsys, arguments, words):
    model, out = tmp_path / "fish.toml", tmp_path / "out.toml"
    model.write_text(DESCRIPTION)
    arguments = [a.format(model=model, out=out) for a in arguments]
    assert main(["--model", str(model), *arguments]) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert model.read_text() == DESCRIPTION and not out.exists()


def test_a_description_that_has_the_table_or_cannot_be_read_is_refused(tmp_path, capsys):
    model, out = tmp_path / "fish.toml", tmp_path / "out.toml"
    model.write_text(DESCRIPTION + '\n[frame_correlation]\nlength = 0.3\nbasis = "x"\n')
    assert main(["--model", str(model), "--seeds", "1", "1", "--out", str(out)]) == 2
    assert "already has a [frame_correlation] table" in capsys.readouterr().err and not out.exists()
    assert main(["--model", str(tmp_path / "none.toml"), "--seeds", "1", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "none.toml: cannot be read" in err and len(err.strip().splitlines()) == 1 and not out.exists()
