"""A project's pointing estimates: estimated from its own repeated picks, double readings and tracked
instants against simulated clicks of a known σ, stored with a date in the project (kept over reopening),
one in use per annotator and source."""

import numpy as np
import pytest

from usvips.app.pointing_settings import (
    add_estimate,
    estimate_double_readings,
    estimate_repeats,
    estimate_tracking,
    pointing_in_use,
    resolve,
    stored_estimates,
    use_estimate,
)
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.pointing_estimates import from_pointing_test
from usvips.store import Project
from usvips.store.project import Vertex


def _vertices(picks: np.ndarray, pair: str = "P1", video: str | None = None, frame: int | None = None):
    return [Vertex(*p, video=video, frame_left=frame, frame_right=frame, pair=pair if video is None else video,
                   time_s=None if frame is None else frame / 25.0)
            for p in picks]


def _fish(rng, count):
    """True picks (2 vertices, xl yl xr yr) of ``count`` fish spread over a 1920 × 1080 image pair."""
    centres = rng.uniform([200, 200], [1700, 900], (count, 2))
    out = []
    for c in centres:
        snout = np.concatenate([c, c - [80, 0]])
        fork = snout + np.tile(rng.uniform(100, 200, 2), 2)
        out.append(np.array([snout, fork]))
    return out


def test_repeats_and_double_readings_estimate_the_clicks_sigma(tmp_path):
    rng = np.random.default_rng(9)
    sigma = {"ana": 0.4, "bo": 0.9}
    with Project.create(tmp_path / "p.usvips") as project:
        for pair in ("P1", "P2", "P3"):
            project.add_pair(pair)
            for truth in _fish(rng, 12):
                for annotator in ("ana", "bo"):
                    times = 3 if annotator == "ana" else 1  # ana measures each fish three times, bo once
                    for _ in range(times):
                        picks = truth + rng.normal(0, sigma[annotator], truth.shape)
                        project.add_object("length", _vertices(picks, pair), creator=annotator)
        found, note = estimate_repeats(project, "ana")
        assert found.method == "repeats" and "108 objects" in note
        assert found.low_px <= sigma["ana"] <= found.high_px and found.n == 36 * 2 * 2
        with pytest.raises(UsvipsError, match="bo has picked no point twice"):
            estimate_repeats(project, "bo")
        both, note = estimate_double_readings(project, "ana", "bo")
        mean_sigma = np.sqrt((sigma["ana"] ** 2 + sigma["bo"] ** 2) / 2)
        assert both.low_px <= mean_sigma <= both.high_px and "36 objects double-read" in note
        with pytest.raises(InvalidParameterError, match="two annotators"):
            estimate_double_readings(project, "ana", "ana")


def test_estimates_are_stored_dated_and_one_is_in_use(tmp_path):
    path = tmp_path / "p.usvips"
    rng = np.random.default_rng(1)
    truth = rng.uniform(0, 500, (20, 2))
    test = from_pointing_test(truth + rng.normal(0, 0.6, truth.shape), truth)
    with Project.create(path) as project:
        assert stored_estimates(project) == [] and pointing_in_use(project) == {}
        first = add_estimate(project, test, "ana", note="pointing test")
        second = add_estimate(project, test, "ana", date="2026-11-01T10:00:00Z")
        add_estimate(project, test, "", source="tracked", use=False)
    with Project.open(path) as project:
        records = stored_estimates(project)
        assert [r.in_use for r in records] == [False, True, False]
        assert records[0].note == "pointing test" and records[0].date == first.date and first.date.endswith("Z")
        assert records[1].estimate == test and records[1].date == second.date
        in_use = pointing_in_use(project)
        assert set(in_use) == {("ana", "hand click")}
        sigma = resolve(in_use, "hand click", "ana")
        assert sigma.origin == "estimated" and sigma.value_px == test.sigma_px and sigma.date == "2026-11-01"
        assert sigma.n == 20 and 0 < sigma.uncertainty_px < sigma.value_px
        assert resolve(in_use, "hand click", "bo") is None and resolve(in_use, "tracked", "ana") is None
        use_estimate(project, 2)
        assert resolve(pointing_in_use(project), "tracked", "bo").value_px == test.sigma_px  # anyone's
        use_estimate(project, None, "ana")
        assert set(pointing_in_use(project)) == {("", "tracked")}
        with pytest.raises(InvalidParameterError, match="no stored estimate 9"):
            use_estimate(project, 8)
        with pytest.raises(InvalidParameterError, match="unknown pointing source"):
            add_estimate(project, test, source="guess")


def test_tracked_instants_give_the_trackers_own_spread(tmp_path):
    rng = np.random.default_rng(4)
    with Project.create(tmp_path / "p.usvips") as project:
        for name in ("left.mkv", "right.mkv"):
            (tmp_path / name).write_bytes(b"a stand-in: the store records the file, nothing reads it here")
        project.add_video("drop", [(tmp_path / "left.mkv", 24, 0.96)], [(tmp_path / "right.mkv", 24, 0.96)], 25.0, 24,
                          (1920, 1080))
        for _ in range(15):
            velocity = rng.uniform(-3, 3, 4)
            start = rng.uniform(300, 900, 4)
            path = [np.array([start, start + [150, 20, 150, 20]]) + f * velocity for f in range(0, 24, 2)]
            noisy = [p + rng.normal(0, 0.3, p.shape) for p in path]
            object_id = project.add_object("length", _vertices(noisy[0], video="drop", frame=0))
            for k, picks in enumerate(noisy[1:], 1):
                instant = project.add_object("length", _vertices(picks, video="drop", frame=2 * k))
                project.add_instant(object_id, instant, tracked_from=0)
        found, note = estimate_tracking(project)
    assert found.method == "tracking" and note == "15 tracked objects"
    assert found.low_px <= 0.3 <= found.high_px


def test_an_estimate_in_use_changes_every_figure_through_the_one_path(tmp_path):
    """Stated σ of hand clicks follow the estimate in use (the figure says so); a σ given by the user stays;
    taking the estimate out of use gives the default again."""
    from dataclasses import replace

    from usvips.app.project_figures import measure_stored
    from usvips.bench.sigma_check import build_survey
    from usvips.core.pointing import HAND_CLICK_SIGMA_PX

    path = build_survey(tmp_path / "s.usvips", objects=3, seed=1)
    rng = np.random.default_rng(2)
    estimate = from_pointing_test(rng.normal(0, 1.2, (40, 2)), np.zeros((40, 2)))
    with Project.open(path) as project:
        first, second, third = project.objects()
        project.update_object(third.id, vertices=[replace(v, pointing_px=(0.3, 0.3), pointing_origin="given")
                                                  for v in third.vertices])
        before = [measure_stored(project, o) for o in project.objects()]
        assert all(np.allclose(m.pointing_sigma_px, HAND_CLICK_SIGMA_PX) for m in before[:2])
        add_estimate(project, estimate, first.creator)
        after = [measure_stored(project, o) for o in project.objects()]
        for b, a in zip(before[:2], after[:2], strict=True):
            assert np.allclose(a.pointing_sigma_px, estimate.sigma_px) and a.pointing_origin == "estimated"
            assert a.main.sigma > 1.5 * b.main.sigma
            assert any("estimated" in mark and "in use for 2 vertex(es)" in mark for mark in a.marks)
        assert np.allclose(after[2].pointing_sigma_px, 0.3) and after[2].main.sigma == before[2].main.sigma
        use_estimate(project, None, first.creator)
        again = measure_stored(project, project.object(second.id))
        assert np.isclose(again.main.sigma, before[1].main.sigma) and again.pointing_origin == "default"


def test_a_tracked_vertex_takes_its_click_and_the_trackers_noise():
    from usvips.app.pointing_settings import pointing_with_estimates
    from usvips.core.pointing import PointingSigma

    click, tracker = PointingSigma(0.6, 0.05, "estimated", "2026-11-28", 40), PointingSigma(0.8, 0.1, "estimated",
                                                                                         "2026-11-28", 30)
    vertices = [Vertex(1, 2, 3, 4, source="tracked", pointing_px=(0.5, 0.5)),
                Vertex(1, 2, 3, 4, source="hand click"), Vertex(1, 2, 3, 4, source="auto-match"),
                Vertex(1, 2, 3, 4, pointing_px=(0.3, 0.3), pointing_origin="given")]
    sigmas, origins, marks = pointing_with_estimates({("ana", "hand click"): click}, vertices, "ana")
    assert sigmas == [(0.6, 0.6)] * 3 + [(0.3, 0.3)] and origins == ["estimated"] * 3 + ["given"]
    assert marks == ("pointing sigma 0.60 ± 0.05 px (estimated, n 40, 2026-11-28) in use for 3 vertex(es)",)
    sigmas, _, _ = pointing_with_estimates({("", "tracked"): tracker, ("ana", "hand click"): click}, vertices, "ana")
    assert sigmas[0] == pytest.approx((1.0, 1.0))  # 0.6 and 0.8 in variance
    sigmas, _, _ = pointing_with_estimates({("", "tracked"): tracker}, vertices, "bo")
    assert sigmas[0] == pytest.approx((np.hypot(0.5, 0.8),) * 2) and sigmas[1] is None  # the click's stored σ
