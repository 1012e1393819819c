"""The object cache's main figures for a sort (``ObjectCache.main_figures``, read from a table kept beside the
figures) are, after any sequence of figures computed, forgotten, objects edited and rules changed, exactly
what asking each object's known figures gives — over random sequences on three random surveys."""

import numpy as np
import pytest

from usvips.core.measurements import QualityRules
from usvips.gui.qt.bench import survey_project
from usvips.gui.workspace import Workspace
from usvips.store import Project


def _asked_one_by_one(cache, ids):
    values, valued, rest = [], [], []
    for object_id in ids:
        known = cache.known_figures(object_id)
        if known is not None and known.figures:
            values.append(known.figures[0].value)
            valued.append(object_id)
        else:
            rest.append(object_id)
    return values, valued, rest


@pytest.mark.parametrize("seed", [2, 7, 13])
def test_main_figures_are_the_known_figures_after_any_changes(tmp_path, seed):
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", 30, seed=seed)))
    cache, rng = ws.cache, np.random.default_rng(seed)
    rule_sets = [ws.rules, QualityRules(max_range_m=3.0), QualityRules(max_ray_rms_m=0.001)]
    try:
        for step in range(60):
            ids = cache.ids()
            some = [int(i) for i in rng.choice(ids, size=int(rng.integers(1, len(ids))), replace=False)]
            action = step % 5 if step < 5 else int(rng.integers(0, 5))
            if action == 0:  # figures computed (in the figures child) and kept
                job = cache.figures_job(some)
                cache.remember(job, job())
            elif action == 1:  # one object's figures computed on the spot
                cache.figures([some[0]])
            elif action == 2:
                cache.forget_figures(some[: max(1, len(some) // 3)])
            elif action == 3:  # an edit drops the object's figures
                ws.edits.edit_object(some[0], f"edited {step}", "")
            else:  # other rules held without the figures forgotten (what the rules' checks guard against)
                ws.rules = rule_sets[int(rng.integers(0, len(rule_sets)))]
            if step < 59 and rng.random() < 0.5:
                continue  # not read after every change: the table must follow the changes between reads too
            order = [int(i) for i in rng.permutation(cache.ids())]
            values, valued, rest = cache.main_figures(order)
            expected_values, expected_valued, expected_rest = _asked_one_by_one(cache, order)
            assert valued.tolist() == expected_valued and rest == expected_rest
            assert values.tolist() == expected_values
            assert cache.missing_figures() == sum(cache.known_figures(i) is None for i in cache.ids())
        assert any(cache.known_figures(i) is not None for i in cache.ids())
    finally:
        ws.close_project()


def test_a_figure_kept_under_other_rules_is_not_read_under_the_first(tmp_path):
    """Figures of all under the rules A and read; the rules B held (not forgotten) and one object's figures
    computed under them; A again: that object's figure is not known under A, though it was when last read."""
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", 12, seed=5)))
    cache = ws.cache
    first, other = ws.rules, QualityRules(max_range_m=3.0)
    try:
        ids = cache.ids()
        job = cache.figures_job(ids)
        cache.remember(job, job())
        assert cache.main_figures(ids)[1].tolist() == ids
        ws.rules = other
        cache.figures([ids[4]])
        ws.rules = first
        values, valued, rest = cache.main_figures(ids)
        assert rest == [ids[4]] and valued.tolist() == [i for i in ids if i != ids[4]]
        assert values.tolist() == _asked_one_by_one(cache, ids)[0]
    finally:
        ws.close_project()
