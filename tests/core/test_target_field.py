"""Finding the rest of a 3-D target field from 6–8 identified targets, on rendered fields of discs over
random poses: in air by a DLT, in air and through a flat port with an earlier calibration's camera
(pose resected, interior and housing held). The truth is each disc centre projected by the camera."""

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.interior import Interior
from usvips.core.observations import ControlPoints
from usvips.core.synth.render import Disc, Water, render
from usvips.core.target_field import find_field, find_field_pair

WIDTH, HEIGHT = 320, 240
RADIUS = 0.025


def field(rng: np.random.Generator, count: int = 26) -> ControlPoints:
    """Discs in a 1.1 × 0.9 × 0.35 m box, at least 0.14 m apart; the first ten on the plane Z = 0."""
    points = []
    while len(points) < count:
        candidate = np.array([rng.uniform(-0.55, 0.55), rng.uniform(-0.45, 0.45),
                              0.0 if len(points) < 10 else rng.uniform(0.0, 0.35)])
        if all(np.linalg.norm(candidate[:2] - p[:2]) > 0.14 for p in points):
            points.append(candidate)
    return ControlPoints(tuple(f"T{i:02d}" for i in range(count)), np.array(points))


def camera_at(rng: np.random.Generator, housing, distance: float) -> Camera:
    interior = Interior(f=350.0, xp=WIDTH / 2 - 0.5 + rng.uniform(-5, 5), yp=HEIGHT / 2 - 0.5 + rng.uniform(-5, 5),
                        k1=-0.08, k2=0.02, p1=2e-4, p2=-1e-4)
    exterior = Exterior(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), distance + rng.uniform(-0.2, 0.2),
                        rng.uniform(-0.12, 0.12), rng.uniform(-0.12, 0.12), rng.uniform(-np.pi, np.pi))
    return Camera(interior, exterior, housing, WIDTH, HEIGHT)


def picture(camera: Camera, control: ControlPoints, seed: int, water: bool) -> np.ndarray:
    discs = [Disc(tuple(c), (0.0, 0.0, 1.0), RADIUS, 0.006) for c in control.xyz]
    medium = Water(attenuation=0.1, backscatter=40, blur=0.6, noise=1.5) if water else \
        Water(attenuation=0.0, backscatter=0.0, blur=0.5, noise=1.0)
    return render(camera, discs, water=medium, supersample=2, background=70, seed=seed)


def truth(camera: Camera, control: ControlPoints, margin: float = 12.0, apart: float = 20.0):
    """True pixels of the disc centres, and which are visible: inside the frame by ``margin`` px and no
    other disc within ``apart`` px (two discs that nearly touch in the image are not one target's)."""
    projection = camera.project(control.xyz)
    pixels = projection.pixels
    inside = projection.ok & (pixels[:, 0] > margin) & (pixels[:, 1] > margin) \
        & (pixels[:, 0] < WIDTH - 1 - margin) & (pixels[:, 1] < HEIGHT - 1 - margin)
    gaps = np.linalg.norm(pixels[:, None] - pixels[None, :], axis=2)
    np.fill_diagonal(gaps, np.inf)
    return pixels, inside & (gaps.min(axis=1) > apart)


CASES = {"air, DLT": ("air", False, 1.8), "air, calibrated": ("air", True, 1.8),
         "flat port, calibrated": ("flat-port", True, 2.6)}


@pytest.mark.parametrize("case", CASES)
def test_found_within_a_fifth_of_a_pixel_none_wrongly_labelled(case):
    housing_name, calibrated, distance = CASES[case]
    rng = np.random.default_rng(list(CASES).index(case) + 40)
    found_share = []
    for trial in range(3):
        control = field(rng)
        camera = camera_at(rng, HOUSINGS[housing_name], distance)
        image = picture(camera, control, trial, housing_name != "air")
        true, visible = truth(camera, control)
        assert visible.sum() >= 15
        clicked = rng.choice(np.flatnonzero(visible), int(rng.integers(6, 9)), replace=False)
        clicks = {control.ids[i]: true[i] + rng.uniform(-2, 2, 2) for i in clicked}
        # an earlier calibration knows the interior and the housing; the pose of this image it does not
        earlier = camera.with_exterior(Exterior(0.0, 0.0, 1.0)) if calibrated else None
        search = find_field(image, control, clicks, earlier)
        by_id = {p.id: p for p in search.points}
        good = 0
        for i, pid in enumerate(control.ids):
            point = by_id[pid]
            if point.status == "found":
                # never a wrong label: a found target is where its own disc is
                assert np.hypot(*(np.array(point.pixel) - true[i])) < 0.5, (case, trial, pid)
            if visible[i] and point.status == "found" and np.hypot(*(np.array(point.pixel) - true[i])) < 0.2:
                good += 1
        found_share.append(good / visible.sum())
        assert search.rms_px < 1.0
        if calibrated:
            assert np.abs(search.camera.exterior.position - camera.exterior.position).max() < 0.01
    assert min(found_share) >= 0.95, found_share


def test_targets_out_of_view_are_missing_and_a_pair_gives_a_view():
    rng = np.random.default_rng(7)
    control = field(rng)
    left = camera_at(rng, HOUSINGS["air"], 1.2)  # nearer: part of the field is out of the frame
    right = left.with_exterior(left.exterior.with_values(X0=left.exterior.X0 + 0.1))
    images = [picture(c, control, k, False) for k, c in enumerate((left, right))]
    clicks = []
    for camera in (left, right):
        true, visible = truth(camera, control)
        chosen = np.flatnonzero(visible)[:8]
        clicks.append({control.ids[i]: true[i] for i in chosen})
    view, left_search, right_search = find_field_pair(images[0], images[1], control, clicks[0], clicks[1],
                                                      (left, right), label="p1")
    true, _ = truth(left, control)
    outside = (true[:, 0] < -0.5) | (true[:, 0] > WIDTH - 0.5) | (true[:, 1] < -0.5) | (true[:, 1] > HEIGHT - 0.5)
    assert outside.sum() > 3
    statuses = {p.id: p for p in left_search.points}
    for i in np.flatnonzero(outside):
        assert statuses[control.ids[i]].status == "missing"
        assert statuses[control.ids[i]].reason == "predicted outside the image"
    assert set(view.left.ids) == set(left_search.ids("found"))
    assert view.label == "p1" and len(view.common_ids()) >= 6
    assert "found" in left_search.summary()


def test_bad_clicks_are_named():
    rng = np.random.default_rng(9)
    control = field(rng)
    camera = camera_at(rng, HOUSINGS["air"], 1.8)
    image = np.full((HEIGHT, WIDTH), 70, np.uint8)
    true, visible = truth(camera, control)
    some = {control.ids[i]: true[i] for i in np.flatnonzero(visible)[:5]}
    with pytest.raises(DegenerateGeometryError, match="at least 6 targets"):
        find_field(image, control, some)
    flat = {control.ids[i]: true[i] for i in range(10) if visible[i]}
    assert len(flat) >= 6
    with pytest.raises(DegenerateGeometryError, match="coplanar"):
        find_field(image, control, flat)
    with pytest.raises(DegenerateGeometryError, match="'X9'"):
        find_field(image, control, {**some, "X9": (10.0, 10.0)})
    with pytest.raises(InvalidParameterError, match="shape"):
        find_field(image, control, some, shape="square")
    with pytest.raises(InvalidParameterError, match="clicks"):
        find_field(image, control, (list(some), np.zeros((3, 2))))


@pytest.mark.parametrize("housing,calibrated,distance", [("air", False, 1.8), ("air", True, 1.8),
                                                         ("flat-port", True, 2.6)])
def test_a_misnamed_click_is_doubtful_and_spoils_nothing(housing, calibrated, distance):
    """Eight clicks, one of them on a target but under another target's id: that click is doubtful
    ("check its id"), the target actually clicked is found under its own id, no other is misplaced."""
    rng = np.random.default_rng(60 + calibrated + 5 * (housing != "air"))
    control = field(rng)
    camera = camera_at(rng, HOUSINGS[housing], distance)
    image = picture(camera, control, 1, housing != "air")
    true, visible = truth(camera, control)
    order = rng.permutation(np.flatnonzero(visible))
    clicked, real = order[:8], order[8]
    wrong = clicked[0]  # the user names `wrong` but clicks on `real`
    assert np.hypot(*(true[wrong] - true[real])) > 40
    clicks = {control.ids[i]: true[i] + rng.uniform(-2, 2, 2) for i in clicked}
    clicks[control.ids[wrong]] = true[real] + rng.uniform(-2, 2, 2)
    earlier = camera.with_exterior(Exterior(0.0, 0.0, 1.0)) if calibrated else None
    search = find_field(image, control, clicks, earlier)
    by_id = {p.id: p for p in search.points}
    assert by_id[control.ids[wrong]].status == "doubtful"
    assert "check its id" in by_id[control.ids[wrong]].reason
    assert by_id[control.ids[real]].status == "found"
    found = 0
    for i, pid in enumerate(control.ids):
        if by_id[pid].status == "found":
            assert np.hypot(*(np.array(by_id[pid].pixel) - true[i])) < 0.5, pid
            found += visible[i]
    assert found >= 0.9 * (visible.sum() - 1)


def test_a_search_stops_when_asked():
    """``cancelled()`` is asked before each target is located: the search stops at the first True."""
    rng = np.random.default_rng(12)
    control = field(rng)
    camera = camera_at(rng, HOUSINGS["air"], 1.8)
    image = picture(camera, control, 0, False)
    true, visible = truth(camera, control)
    clicks = {control.ids[i]: true[i] for i in np.flatnonzero(visible)[-8:]}  # off the plane Z = 0 too
    asked = []

    def cancelled():
        asked.append(1)
        return len(asked) > 12

    with pytest.raises(InterruptedError, match="stopped"):
        find_field(image, control, clicks, cancelled=cancelled)
    assert len(asked) == 13
    assert find_field(image, control, clicks, cancelled=lambda: False).summary()
