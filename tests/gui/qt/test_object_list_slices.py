"""The object list while objects come a slice at a time (a detection run's proposals stored and told a
slice a turn of the event loop, issue 35): a slice arriving while a figures job runs waits next in line
instead of replacing the job (whose objects' inputs the window's thread would copy again with each slice);
objects changed while their job ran are computed again after it; and an object a job holds is never
computed on the window's thread as well."""

from tests.gui.qt.test_object_table import _survey_list
from usvips.gui.qt.object_list import ObjectList
from usvips.store.records import Vertex


def _store(ws, count: int, start: float = 0.0) -> tuple[int, ...]:
    return tuple(ws.project.add_object("point", [Vertex(300.0 + start + k, 200.0, 280.0 + start + k, 200.0,
                                                         pair="measure1")]) for k in range(count))


def test_slices_stored_while_a_job_runs_wait_for_it_and_every_figure_comes(qtbot, tmp_path, monkeypatch):
    ws, listing, jobs = _survey_list(qtbot, tmp_path, monkeypatch, 20)
    monkeypatch.setattr(ObjectList, "EAGER", 1000)  # a small list: every object's figures are wanted
    jobs.clear()
    first = _store(ws, 4)
    ws.objects_changed_in_store(added=first)
    running = listing._worker
    assert running is not None and jobs == [list(first)]
    slices = [_store(ws, 4, 10.0 * (k + 1)) for k in range(3)]
    for piece in slices:  # (no turn of the event loop between them: the job is still the running one)
        ws.objects_changed_in_store(added=piece)
    assert listing._worker is running and not running.is_cancelled and jobs == [list(first)]
    assert set(listing._queue) == {i for piece in slices for i in piece}
    qtbot.waitUntil(lambda: listing._worker is None, timeout=20000)
    copied = [i for job in jobs for i in job]
    assert sorted(copied) == sorted([*first, *(i for piece in slices for i in piece)])  # each copied once
    assert all(ws.cache.known_figures(i) is not None for i in copied)
    listing.cleanup()
    ws.close_project()


def test_an_object_changed_while_its_job_runs_is_computed_again_after_it(qtbot, tmp_path, monkeypatch):
    ws, listing, jobs = _survey_list(qtbot, tmp_path, monkeypatch, 20)
    monkeypatch.setattr(ObjectList, "EAGER", 1000)
    jobs.clear()
    new = _store(ws, 4)
    ws.objects_changed_in_store(added=new)
    assert listing._pending == list(new)
    ws.project.update_object(new[0], attribute="moved")
    ws.objects_changed_in_store(updated=(new[0],))  # its version moves: the running job's figure is dropped
    qtbot.waitUntil(lambda: listing._worker is None, timeout=20000)
    assert ws.cache.known_figures(new[0]) is not None
    assert [job for job in jobs if new[0] in job] == [list(new), [new[0]]]
    listing.cleanup()
    ws.close_project()


def test_an_object_a_job_holds_is_not_computed_on_the_windows_thread_too(qtbot, tmp_path, monkeypatch):
    ws, listing, jobs = _survey_list(qtbot, tmp_path, monkeypatch, 20)
    new = _store(ws, 4)
    ws.objects_changed_in_store(added=new)
    assert listing._worker is not None
    at_once = []
    figures = ws.figures
    monkeypatch.setattr(ws, "figures", lambda ids: at_once.append(list(ids)) or figures(ids))
    listing._compute([new[0]])  # a drawn row asks for a figure its job is computing
    listing._compute([new[1], new[2]])
    assert at_once == []
    qtbot.waitUntil(lambda: listing._worker is None, timeout=20000)
    assert all(ws.cache.known_figures(i) is not None for i in new)
    listing.cleanup()
    ws.close_project()
