"""Phase 2 from several physically distinct starts: a System I rig whose best single start ends with a
glass thickness on its bound calibrates cleanly once the next-best starts are tried too."""

from __future__ import annotations

from tests.core.test_calibration_monte_carlo import _clean, _one_rig, _system_one
from usvips.core.calibration import phases

STICKY_RIG = 1011  # a draw of the Monte Carlo whose best exterior-only start leads the full run onto t = 0


def test_a_rig_that_sticks_from_one_start_is_clean_from_several(monkeypatch):
    run = _one_rig(_system_one, STICKY_RIG)
    assert _clean(run), run["report"]["notes"]
    monkeypatch.setattr(phases, "EXTRA_STARTS", 0)
    single = _one_rig(_system_one, STICKY_RIG)
    assert not _clean(single)  # the same rig from its best single start (the mechanism is what helps)
    assert any("ends on its lower bound" in note for note in single["report"]["notes"])
