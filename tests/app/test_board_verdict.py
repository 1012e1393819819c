"""One verdict on a calibration from target views, consistent with the coverage advice beside it: never
"the fit is consistent" while the advice says to film more."""

from types import SimpleNamespace

import pytest

from usvips.app.board_verdict import judge


def _calibration(sigma0=0.3, fitted=0.2, held=None):
    validation = None if held is None else SimpleNamespace(fitted=SimpleNamespace(rms_px=fitted),
                                                           held_out=SimpleNamespace(rms_px=held))
    return SimpleNamespace(result=SimpleNamespace(report=SimpleNamespace(sigma0_px=sigma0)), validation=validation)


def _coverage(views, advice=()):
    return SimpleNamespace(views=views, advice=tuple(advice))


@pytest.mark.parametrize("views", [3, 5, 14])
def test_few_views_are_a_trial_whatever_the_fit(views):
    verdict = judge(_calibration(held=0.21), _coverage(views, [f"only {views} views: film at least 15"]), 0.5)
    assert verdict.level == "short" and "the fit is consistent" not in verdict.text
    assert "film at least 15" in verdict.text and "held-out views agree" in verdict.text


def test_advice_left_makes_it_short_and_says_it():
    verdict = judge(_calibration(), _coverage(20, ["nothing in the upper left of the left image"]), 0.5)
    assert verdict.level == "short" and "upper left" in verdict.text


def test_a_sound_fit_from_covering_views_is_consistent():
    verdict = judge(_calibration(held=0.25), _coverage(20), 0.5)
    assert verdict.level == "good" and verdict.text.startswith("the fit is consistent and the held-out views agree")


def test_a_misfit_or_a_calibration_that_does_not_generalise_is_poor_before_anything_else():
    assert judge(_calibration(sigma0=3.0), _coverage(20), 0.5).level == "poor"  # 6 × the pointing σ
    poor = judge(_calibration(fitted=0.1, held=0.5), _coverage(3, ["film at least 15"]), 0.5)
    assert poor.level == "poor" and "does not generalise" in poor.text
