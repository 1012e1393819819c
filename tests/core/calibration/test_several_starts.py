"""Phase 2 from several physically distinct starts: a System I rig whose best single start ends with a
glass thickness on its bound calibrates cleanly once the next-best starts are tried too."""

from __future__ import annotations

from tests.core.test_calibration_monte_carlo import _clean, _one_rig, _system_one
from usvips.core.calibration import phases

STICKY_RIG = 1011  # a draw of the Monte Carlo whose best exterior-only start leads the full run onto t = 0


def test_a_rig_that_sticks_from_one_start_is_clean_from_several(monkeypatch):
    run = _one_rig(_system_one, STICKY_RIG)
    assert _clean(run), run["report"].notes
    monkeypatch.setattr(phases, "EXTRA_STARTS", 0)
    single = _one_rig(_system_one, STICKY_RIG)
    assert not _clean(single)  # the same rig from its best single start (the mechanism is what helps)
    assert any("ends on its lower bound" in note for note in single["report"].notes)


def _run(sigma0_px: float, redundancy: int = 60, excluded: int = 0, converged: bool = True, on_bound=()):
    from types import SimpleNamespace

    adjustment = SimpleNamespace(converged=converged, on_bound=list(on_bound), excluded=[object()] * excluded,
                                 sigma0=sigma0_px / 0.5, redundancy=redundancy)
    return SimpleNamespace(adjustment=adjustment, calibration=SimpleNamespace(sigma0_px=sigma0_px))


def test_a_run_with_residuals_far_above_another_loses_even_with_fewer_observations_set_aside():
    from usvips.core.calibration.phases import _better

    local_minimum, true_fit = _run(0.95, excluded=0), _run(0.32, excluded=3)
    assert _better(true_fit, local_minimum) and not _better(local_minimum, true_fit)
    # within chance the fewer set-aside observations still win; convergence and bounds come first
    assert _better(_run(0.40, excluded=0), _run(0.38, excluded=2))
    assert _better(_run(0.95), _run(0.32, converged=False))
    assert _better(_run(0.95), _run(0.32, on_bound=("t",)))


def test_phase_two_far_worse_than_phase_one_sends_it_to_other_starts():
    from usvips.core.calibration.phases import _fits_worse_than_in_air

    assert _fits_worse_than_in_air(_run(0.95, redundancy=88), (0.38, 78))
    assert not _fits_worse_than_in_air(_run(0.42, redundancy=88), (0.38, 78))
    assert not _fits_worse_than_in_air(_run(0.95, redundancy=88), None)


def test_tau_rejections_send_a_run_to_other_starts_only_beyond_chance():
    from scipy.stats import poisson

    from usvips.core.adjustment import ALPHA0
    from usvips.core.calibration.phases import CHANCE_REJECTIONS_LEVEL, chance_rejections

    assert chance_rejections(100) == 2  # a tank's hundred observations: two rejections are no chance
    previous = 2
    for n in (10, 300, 1000, 3000, 7372, 10384, 30000, 100000):
        count, expected = chance_rejections(n), n * ALPHA0
        assert count >= previous and count >= 2
        # blunder-free data reach ``count`` rejections rarely, ``count - 1`` too often to call it a symptom
        assert poisson.sf(count - 1, expected) <= CHANCE_REJECTIONS_LEVEL
        assert count == 2 or poisson.sf(count - 2, expected) > CHANCE_REJECTIONS_LEVEL
        previous = count
    assert chance_rejections(10384) > 10384 * ALPHA0  # a survey's ~10 false alarms do not trigger them
