"""The swimming, bending fish of the renderer: its body keeps its length, bends, moves, and is drawn
where its truth projects."""

import numpy as np
import pytest

from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.housing import AirHousing
from usvips.core.interior import Interior
from usvips.core.synth.swimming import SwimmingFish


def test_the_midline_keeps_the_fork_length_while_the_chord_shortens_as_it_bends():
    fish = SwimmingFish(start=(0.0, 0.0, -2.0), length=0.4, speed=0.25, bend=0.8)
    chords = []
    for t in np.linspace(0.0, 1.0, 11):
        points, s = fish.midline(t, np.linspace(0.0, fish.length, 2001))
        assert np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)) == pytest.approx(0.4, rel=1e-5)
        chords.append(np.linalg.norm(np.diff(fish.snout_fork(t), axis=0)))
        assert fish.snout_fork(t)[0] == pytest.approx([0.25 * t, 0.0, -2.0])
        assert fish.snout_fork(t)[1][0] < fish.snout_fork(t)[0][0]  # the body trails the snout
    assert max(chords) <= 0.4 and max(chords) - min(chords) > 0.005
    straight = SwimmingFish(start=(0.0, 0.0, -2.0), length=0.4, bend=0.0)
    assert np.linalg.norm(np.diff(straight.snout_fork(0.3), axis=0)) == pytest.approx(0.4)


def test_a_rendered_body_point_shows_the_texture_where_its_truth_projects():
    camera = Camera(Interior(400.0, 160.0, 120.0, 1.0), Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), AirHousing(), 320, 240)
    fish = SwimmingFish(start=(-0.2, 0.0, -1.5), length=0.3, bend=0.5, seed=4)
    for t in (0.0, 0.3):
        for s, v in ((0.05, 0.0), (0.12, 0.02), (0.2, -0.01)):
            point = fish.body_point(t, s, v)
            bundle = camera.rays(camera.project(point[None]).pixels)
            hit_t, grey = fish.at(t).hit(bundle.origins, bundle.directions)
            # the sheet stands on a polyline of the midline: within 20 µm of the smooth body
            assert bundle.origins[0] + hit_t[0] * bundle.directions[0] == pytest.approx(point, abs=2e-5)
            assert grey[0] == pytest.approx(float(fish.texture(np.array(s), np.array(v))), abs=0.5)
        # a ray beside the fish misses it
        bundle = camera.rays(np.array([[5.0, 5.0]]))
        assert np.isinf(fish.at(t).hit(bundle.origins, bundle.directions)[0][0])


def test_a_fish_swimming_up_its_own_back_is_refused():
    with pytest.raises(InvalidParameterError, match="up"):
        SwimmingFish(start=(0.0, 0.0, -2.0), heading=(0.0, 1.0, 0.0), up=(0.0, 1.0, 0.0))
