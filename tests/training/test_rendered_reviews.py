"""Rendered clips reviewed by the truth: every fish to find in both images is an accepted length at its true
snout and fork pixels, and the project exports as a training set that reads back as training frames."""

import numpy as np

from usvips.app.training_set import export_training_set
from usvips.core.synth.stereo_survey import survey_clip
from usvips.store import Project
from usvips.training.rendered_reviews import SIZE, main
from usvips.training.training_set_frames import read_training_set


def test_the_fish_to_find_in_both_images_are_accepted_at_their_true_pixels(tmp_path, capsys):
    seeds = (50_500_000, 50_500_001, 50_500_002)
    assert main([str(tmp_path / "clips"), "--clips", "3", "--first-seed", str(seeds[0])]) == 0
    expected = {}
    for c, seed in enumerate(seeds):
        clip = survey_clip(seed, SIZE, frames=2, step=10)
        for f, frame in enumerate(clip.frames):
            for left, right in zip(frame.left_truth, frame.right_truth, strict=True):
                if left.required and right.required:
                    pixels = np.hstack([left.keypoints[:2], right.keypoints[:2]])
                    expected.setdefault((f"clip{c}", f), []).append(pixels)
    with Project.open(tmp_path / "clips" / "acceptance.usvips") as project:
        accepted = {r.object_id for r in project.reviews("accepted")}
        stored = project.objects_with_ids(sorted(accepted))
        found = {}
        for o in stored:
            v = o.vertices
            found.setdefault((v[0].video, v[0].frame_left), []).append(
                np.array([[x.xl, x.yl, x.xr, x.yr] for x in v]))
        written, _, skipped = export_training_set(project, tmp_path / "reviewed")
    assert sum(map(len, expected.values())) == len(stored) >= 3 and skipped == []
    assert found.keys() == expected.keys()
    for key, points in expected.items():
        np.testing.assert_allclose(np.array(found[key]), np.array(points), atol=1e-9)
    assert len(read_training_set(tmp_path / "reviewed").names) == written == 2 * len(stored)
    assert f"{len(stored)} accepted lengths on 3 clips" in capsys.readouterr().out
    assert main([str(tmp_path / "clips")]) == 2 and "exists" in capsys.readouterr().err
